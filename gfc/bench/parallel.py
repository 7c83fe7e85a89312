"""The task benchmark with each trial planned *and* executed in a pool worker.

``run_benchmark`` (gfc/bench/tasks.py) plans in this process, one trial at a time, while the
pool executes the chunk before. That kept the cores busy while plans were cheap. Dense plans are
not: Packing T3's GFC plan (32 candidates, a Langevin corrector step per sampling step, the
kinematic screen) is ~26 s of CPU and its execution ~6 s, so planning alone paced the run and the
two simulator processes idled most of the time. Here each worker takes a whole trial (plan, then
execute), so every core plans.

The trials are the same ones: a plan depends only on the scene, the settings, the models and
its seed (``Options.seed``, a ``torch.Generator`` per plan; the screen is seeded by the scene),
never on what the process did before, so a worker's plan equals the one this process would make,
bit for bit (``tests/bench/test_parallel.py`` checks it). Planning time is still the CPU time of
the planner's call, now in the worker, where nothing else runs alongside it.

Workers get the models by description (``LibrarySpec``: a store location, or random weights for
a plumbing check), not as objects: plain data crosses process boundaries, and each worker loads a
library once and keeps it for the trials it is given.

This module is bookkeeping (which process runs what), not outcome code, so it is left out of the
code fingerprint of trial logs (gfc/bench/trial_log.py); a log made with either scheduler can be
continued with the other.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from gfc.bench.methods import Method, PlanSettings, make_method, needs_models
from gfc.bench.tasks import (
    BenchResult,
    Progress,
    Trial,
    TrialRecord,
    as_execution,
    execute_trial,
    random_weights_library,
    run_benchmark,
)
from gfc.planner.library import SkillLibrary
from gfc.pool import Pool
from gfc.tasks import sample_task


@dataclass(frozen=True)
class LibrarySpec:
    """Where a worker gets its skill models: a skill store (the latest version of each model), or
    random weights for the models of ``random_for``'s tasks (checks the plumbing only)."""

    store: str | None = None
    random_for: tuple[str, ...] = ()

    def load(self) -> SkillLibrary:
        if self.store is not None:
            from skill_store import SkillStore, StoreLibrary

            return StoreLibrary(SkillStore(self.store))
        if self.random_for:
            return random_weights_library(self.random_for)
        raise ValueError("a LibrarySpec names a store or the tasks to make random weights for")


@dataclass(frozen=True)
class TrialJob:
    """One trial as plain data: what a worker needs to plan and execute it."""

    task: str
    method: str
    seed: int
    settings: PlanSettings
    library: LibrarySpec | None  # None: the method uses no models
    threads: int  # torch CPU threads for planning (the benchmark's --threads)


# Per worker process: libraries and planners load once and serve every trial the worker gets.
# Models only, no simulator: every execution still builds its own physics client.
_LIBRARIES: dict[LibrarySpec, SkillLibrary] = {}
_PLANNERS: dict[tuple[LibrarySpec | None, str], Method] = {}


def _planner(library: LibrarySpec | None, method: str) -> Method:
    key = (library, method)
    if key not in _PLANNERS:
        models = None
        if library is not None and needs_models(method):
            if library not in _LIBRARIES:
                _LIBRARIES[library] = library.load()
            models = _LIBRARIES[library]
        _PLANNERS[key] = make_method(method, models)
    return _PLANNERS[key]


def plan_and_execute(job: TrialJob) -> Trial:
    """Plan one trial and execute its top candidates (pool-safe: module level, plain data)."""
    import torch

    if torch.get_num_threads() != job.threads:
        torch.set_num_threads(job.threads)
    plan = _planner(job.library, job.method)(sample_task(job.task, job.seed), job.settings)
    work = as_execution(job.task, job.seed, plan)
    outcome = execute_trial(work)
    return Trial(
        job.task,
        job.method,
        job.seed,
        plan.seconds,
        outcome,
        work.candidates[0],
        plan.passed_screen,
        plan.rounds,
    )


def run_benchmark_in_workers(
    tasks: Sequence[str],
    methods: Sequence[str],
    trials: int,
    library: LibrarySpec | None,
    pool: Pool,
    settings: PlanSettings = PlanSettings(),
    threads: int = 1,
    seed: int = 0,
    chunk: int = 16,
    on_progress: Progress | None = None,
    log: TrialRecord | None = None,
) -> BenchResult:
    """``run_benchmark``'s trials (same scenes, seeds, settings, log and progress units), each
    planned and executed by a pool worker. A chunk's trials are appended to the log once the
    chunk is done, so an interrupted run loses at most one chunk."""
    report = on_progress or (lambda _msg, _n: None)
    # run_benchmark without executing: refuses bad input (unknown tasks or methods, too few
    # candidates, missing models, all named) before any work, and takes the trials the log holds.
    models = library.load() if library is not None and any(needs_models(m) for m in methods) else None
    logged = run_benchmark(
        tasks, methods, trials, models, pool, settings, seed=seed, on_progress=report, log=log, execute=False
    )
    done = {(t.task, t.method, t.seed): t for t in logged.trials}
    result = BenchResult(list(tasks), list(methods))
    for task in tasks:
        keys = [(task, method, seed + i) for method in methods for i in range(trials)]
        todo = [k for k in keys if k not in done]
        for start in range(0, len(todo), chunk):
            part = todo[start : start + chunk]
            names = sorted({method for _, method, _ in part})
            report(f"{task}: planning and executing ({', '.join(names)})", 0)
            jobs = [TrialJob(task, method, s, settings, library, threads) for _, method, s in part]
            for trial in pool.map(plan_and_execute, jobs):
                done[(task, trial.method, trial.seed)] = trial
                if log is not None:
                    log.append(trial)
            report(f"{task}: planning and executing ({', '.join(names)})", 2 * len(part))
        result.trials += [done[k] for k in keys if k in done]
    return result
