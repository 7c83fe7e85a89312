"""The benchmark with whole trials in pool workers (gfc/bench/parallel.py): the same trials as
planning here, the log resumed, bad input refused before any work."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import pytest

from gfc.bench.methods import MissingModelsError, PlanSettings
from gfc.bench.parallel import LibrarySpec, TrialJob, run_benchmark_in_workers
from gfc.bench.tasks import ExecutionResult, Trial, run_benchmark
from gfc.bench.trial_log import TrialLog
from gfc.planner.library import InMemoryLibrary
from gfc.pool import InlinePool, LocalPool

TASK = "pot_reorientation"


class RecordingPool:
    """Stands in for the workers: records the jobs, 'succeeds' a trial when its seed is even."""

    def __init__(self) -> None:
        self.jobs: list[TrialJob] = []

    def map(self, fn: Callable[[Any], Any], items: Iterable[TrialJob]) -> list[Trial]:
        out = []
        for job in items:
            self.jobs.append(job)
            ok = job.seed % 2 == 0
            out.append(Trial(job.task, job.method, job.seed, 0.5, ExecutionResult(ok, ok, None, ok, 1), ()))
        return out


def test_a_resumed_run_sends_only_the_missing_trials_and_logs_each(tmp_path: Path) -> None:
    log = TrialLog(tmp_path / "t.jsonl", {"settings": {}, "models": {}})
    settings = PlanSettings(candidates=5)
    pool = RecordingPool()
    units: list[int] = []
    run_benchmark_in_workers([TASK], ["random"], 3, None, pool, settings, chunk=2, log=log)
    assert [(j.method, j.seed) for j in pool.jobs] == [("random", 0), ("random", 1), ("random", 2)]
    assert all(j.settings == settings and j.library is None and j.threads == 1 for j in pool.jobs)
    again = RecordingPool()
    result = run_benchmark_in_workers(
        [TASK],
        ["random"],
        5,
        None,
        again,
        settings,
        chunk=2,
        log=log,
        on_progress=lambda _m, n: units.append(n),
    )
    assert [j.seed for j in again.jobs] == [3, 4]
    assert [t.seed for t in result.trials] == [0, 1, 2, 3, 4] and len(log) == 5
    assert sum(units) == 2 * 5  # the same progress units as run_benchmark: plan + execute per trial


def test_bad_input_is_refused_before_any_work() -> None:
    pool = RecordingPool()
    with pytest.raises(KeyError, match="unknown tasks"):
        run_benchmark_in_workers(["no_such_task"], ["random"], 1, None, pool)
    with pytest.raises(KeyError, match="unknown methods"):
        run_benchmark_in_workers([TASK], ["oracle"], 1, None, pool)
    with pytest.raises(ValueError, match="any-5 needs at least 5 candidates"):
        run_benchmark_in_workers([TASK], ["random"], 1, None, pool, PlanSettings(candidates=3))
    with pytest.raises(MissingModelsError, match=r"move\.pot, pick\.pot"):
        run_benchmark_in_workers([TASK], ["gfc"], 1, None, pool)
    with pytest.raises(MissingModelsError, match=r"pick\.pot"):
        run_benchmark_in_workers([TASK], ["gfc"], 1, LibrarySpec(store="/nonexistent/store"), pool)
    with pytest.raises(ValueError, match="names a store or the tasks"):
        LibrarySpec().load()
    assert pool.jobs == []


@pytest.mark.slow
def test_workers_make_the_same_trials_as_planning_here() -> None:
    """Two worker processes (spawned: their torch and models are their own) against planning in
    this process, with random weights: the same candidates to the last bit, the same outcomes."""
    settings = PlanSettings(candidates=5, steps=3)
    spec = LibrarySpec(random_for=(TASK,))
    here = run_benchmark([TASK], ["gfc", "random"], 2, spec.load(), InlinePool(), settings)
    with LocalPool(2, keep_alive=True) as pool:
        there = run_benchmark_in_workers([TASK], ["gfc", "random"], 2, spec, pool, settings)
    assert [(t.method, t.seed) for t in there.trials] == [
        ("gfc", 0),
        ("gfc", 1),
        ("random", 0),
        ("random", 1),
    ]
    assert [(t.top1_actions, t.result, t.passed_screen) for t in there.trials] == [
        (t.top1_actions, t.result, t.passed_screen) for t in here.trials
    ]


def test_a_store_spec_loads_the_store(tmp_path: Path) -> None:
    from skill_store import StoreLibrary

    library = LibrarySpec(store=str(tmp_path / "store")).load()
    assert isinstance(library, StoreLibrary)
    assert isinstance(LibrarySpec(random_for=(TASK,)).load(), InMemoryLibrary)
