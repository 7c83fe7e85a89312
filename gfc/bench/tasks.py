"""Task benchmark (issue 6): success rates of planners on the simulated tasks.

For every task and method, ``trials`` scenes (seeds ``seed``, ``seed + 1``, ...; the same scenes
for every method, so methods are compared pairwise) are sampled, planned and executed:

- **top-1**: only the best-ranked candidate is executed; a trial succeeds when every step
  succeeds and the goal holds in the simulator afterwards (``PlanOutcome.success``).
- **any-5**: the top five candidates are executed in turn, each in a fresh world, until one
  succeeds; a trial succeeds when one does. Top-1's execution is any-5's first, so any-5 >= top-1.
- **failures** of the top-1 executions, by step and failure type (1 method/IK, 2 path, 3
  physics: ``gfc.sim.outcome.FailureType``), as in the paper's appendix tables. Execution stops
  at the first failed stage, so each failed trial is counted once, at its first failed step (for
  a group, the group's first step); trials whose steps all succeed but whose goal does not hold
  are ``goal_not_met``. Hence ``sum(by_type) + goal_not_met + succeeded == trials``.
- **planning time**: the median CPU time of a method's call per trial, in this process (with one
  torch thread, the wall clock it takes on an idle core).

Planning runs in this process, one trial at a time; execution fans out over the simulation pool
(``gfc.pool``) in chunks, each chunk executing while the next is planned. Until session 9 the two
took turns, and planning time was wall clock (undisturbed then): a core idled in every phase.
"""

from __future__ import annotations

import statistics
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from gfc.bench.methods import (
    METHODS,
    ORACLES,
    Method,
    MethodPlan,
    MissingModelsError,
    PlanSettings,
    check_models,
    make_method,
    needs_models,
    required_models,
)
from gfc.diffusion.denoiser import StackedDenoiser
from gfc.plan.compiler import compile_plan
from gfc.planner.library import InMemoryLibrary, SkillLibrary, random_library
from gfc.pool import Pool
from gfc.sim.outcome import FailureType, PlanOutcome
from gfc.tasks import ALL_TASKS, sample_task

ANY_K = 5  # candidates tried in turn for "any-5"
FAILURE_TYPES = tuple(str(int(t)) for t in FailureType)  # "1", "2", "3"

Progress = Callable[[str, int], None]  # (description, units done since the last call)


@dataclass(frozen=True)
class Execution:
    """One trial's execution work: plain data, so it crosses process boundaries."""

    task: str
    seed: int
    candidates: tuple[tuple[tuple[float, ...] | None, ...], ...]  # best first, at most ANY_K


@dataclass(frozen=True)
class StepFailure:
    step: int
    skill: str
    failure_type: int
    reason: str


@dataclass(frozen=True)
class ExecutionResult:
    top1_success: bool
    top1_goal: bool
    top1_failure: StepFailure | None  # None: every step succeeded (the goal may still fail)
    any_success: bool
    tried: int


@dataclass(frozen=True)
class Trial:
    task: str
    method: str
    seed: int
    plan_seconds: float
    result: ExecutionResult
    top1_actions: tuple[tuple[float, ...] | None, ...]  # kept to re-run it for key frames
    passed_screen: int | None = None  # MethodPlan.passed_screen; None: unscreened or not logged
    rounds: int | None = None  # MethodPlan.rounds (sampling rounds drawn); None: not logged


@dataclass
class BenchResult:
    tasks: list[str]
    methods: list[str]
    trials: list[Trial] = field(default_factory=list)


def as_execution(task: str, seed: int, plan: MethodPlan) -> Execution:
    candidates = tuple(
        tuple(None if a is None else tuple(float(v) for v in a) for a in actions)
        for actions in plan.candidates[:ANY_K]
    )
    return Execution(task, seed, candidates)


def to_arrays(actions: Sequence[Sequence[float] | None]) -> list[np.ndarray | None]:
    return [None if a is None else np.asarray(a, dtype=np.float64) for a in actions]


def _first_failure(outcome: PlanOutcome) -> StepFailure | None:
    first = outcome.first_failure
    if first is None:
        return None
    assert first.failure_type is not None  # a failed step always carries its type
    return StepFailure(first.step, first.skill, first.failure_type, first.reason)


def execute_trial(item: Execution) -> ExecutionResult:
    """Execute a trial's candidates in turn (each in a fresh world) until one succeeds. (Pool-safe.)"""
    from gfc.sim.execute import execute_plan

    instance = sample_task(item.task, item.seed)
    top1: PlanOutcome | None = None
    success, tried = False, 0
    for actions in item.candidates:
        outcome = execute_plan(instance.plan, to_arrays(actions), seed=item.seed, contents=instance.contents)
        tried += 1
        top1 = top1 or outcome
        if outcome.success:
            success = True
            break
    if top1 is None:
        raise ValueError(f"{item.task} seed {item.seed}: no candidates to execute")
    return ExecutionResult(top1.success, top1.goal_satisfied, _first_failure(top1), success, tried)


def check_library(tasks: Sequence[str], methods: Sequence[str], library: SkillLibrary | None) -> None:
    """Fail before any work when a learned method lacks models for any task, naming them all."""
    if not any(needs_models(m) for m in methods):
        return
    refs = sorted({ref for task in tasks for ref in required_models(compile_plan(sample_task(task, 0).plan))})
    if library is None:
        raise MissingModelsError(dict.fromkeys(refs, "no skill library given"))
    check_models(library, refs)


def random_weights_library(tasks: Sequence[str], seed: int = 0) -> InMemoryLibrary:
    """Randomly initialised models for every model key the tasks need: checks the harness's
    plumbing without trained skills (success rates are then meaningless)."""
    models: dict[str, StackedDenoiser] = {}
    for task in tasks:
        library = random_library(compile_plan(sample_task(task, 0).plan), seed=seed)
        for name, model in library.models.items():
            models.setdefault(name, model)
    return InMemoryLibrary(models)


class TrialRecord(Protocol):
    """Where finished trials are kept across runs (``gfc.bench.trial_log.TrialLog``)."""

    def get(self, key: tuple[str, str, int]) -> Trial | None: ...

    def append(self, trial: Trial) -> None: ...


def run_benchmark(
    tasks: Sequence[str],
    methods: Sequence[str],
    trials: int,
    library: SkillLibrary | None,
    pool: Pool,
    settings: PlanSettings = PlanSettings(),
    seed: int = 0,
    chunk: int = 16,
    on_progress: Progress | None = None,
    log: TrialRecord | None = None,
    execute: bool = True,
    pipeline: bool = True,
) -> BenchResult:
    """Plan and execute ``trials`` scenes per task and method. Progress units: one per trial
    planned and one per trial executed (``2 * len(tasks) * len(methods) * trials`` in all).

    With a ``log``, trials it already holds are taken from it instead of being redone, and each
    new trial is appended to it as soon as its chunk has been executed: an interrupted run loses
    at most two chunks (one executing, the next planned). With ``execute=False`` nothing is
    planned or run: the result holds the log's trials only (a report of what has been measured
    so far). With ``pipeline`` (the default) a chunk is planned while the one before it
    executes; without, in turn. Either way the trials are the same."""
    unknown = [t for t in tasks if t not in ALL_TASKS]
    if unknown:
        raise KeyError(f"unknown tasks {unknown} (known: {', '.join(sorted(ALL_TASKS))})")
    bad = [m for m in methods if m not in METHODS + ORACLES]
    if bad:
        raise KeyError(f"unknown methods {bad} (known: {', '.join(METHODS + ORACLES)})")
    if settings.candidates < ANY_K:
        raise ValueError(f"any-{ANY_K} needs at least {ANY_K} candidates, got {settings.candidates}")
    check_library(tasks, methods, library)
    report = on_progress or (lambda _msg, _n: None)
    planners = {m: make_method(m, library if needs_models(m) else None) for m in methods}
    result = BenchResult(list(tasks), list(methods))
    for task in tasks:
        keys = [(task, method, seed + i) for method in methods for i in range(trials)]
        logged = {k: log.get(k) for k in keys} if log is not None else {}
        done = {k: t for k, t in logged.items() if t is not None}
        if done:
            report(f"{task}: {len(done)} trials from the log", 2 * len(done))
        todo = [k for k in keys if k not in done] if execute else []
        for trial in _plan_and_execute(task, todo, planners, settings, pool, chunk, pipeline, report):
            done[(task, trial.method, trial.seed)] = trial
            if log is not None:
                log.append(trial)
        result.trials += [done[k] for k in keys if k in done]
    return result


Planned = list[tuple[str, int, MethodPlan]]  # (method, seed, candidates) per trial of a chunk


def _plan_and_execute(
    task: str,
    todo: Sequence[tuple[str, str, int]],
    planners: dict[str, Method],
    settings: PlanSettings,
    pool: Pool,
    chunk: int,
    pipeline: bool,
    report: Progress,
) -> Iterator[Trial]:
    """The trials of ``todo`` (task, method, seed), chunk by chunk, each yielded once executed.

    With ``pipeline`` the pool executes one chunk while this process plans the next (a thread
    waits on the pool), so the CPUs no longer idle in turn; planning time is CPU time
    (methods.py), which the simulations running alongside do not inflate."""

    def finished(planned: Planned, work: list[Execution], outcomes: list[ExecutionResult]) -> list[Trial]:
        report(f"{task}: executing", len(work))
        return [
            Trial(
                task, method, seed, plan.seconds, outcome, item.candidates[0], plan.passed_screen, plan.rounds
            )
            for (method, seed, plan), item, outcome in zip(planned, work, outcomes, strict=True)
        ]

    pending: tuple[Planned, list[Execution], Future[list[ExecutionResult]]] | None = None
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="bench-execute") as runner:
        for start in range(0, len(todo), chunk):
            planned: Planned = []
            for _, method, seed in todo[start : start + chunk]:
                planned.append((method, seed, planners[method](sample_task(task, seed), settings)))
                report(f"{task}: planning ({method})", 1)
            work = [as_execution(task, seed, plan) for _, seed, plan in planned]
            if pending is not None:
                yield from finished(pending[0], pending[1], pending[2].result())
            pending = (planned, work, runner.submit(pool.map, execute_trial, work))
            if not pipeline:
                yield from finished(planned, work, pending[2].result())
                pending = None
        if pending is not None:
            yield from finished(pending[0], pending[1], pending[2].result())


def failure_table(task: str, trials: Sequence[Trial]) -> dict[str, Any]:
    """Top-1 failures of one task and method: per step (type counts), totals, goal misses."""
    skeleton = sample_task(task, 0).plan.skeleton
    counts = [dict.fromkeys(FAILURE_TYPES, 0) for _ in skeleton]
    goal_not_met = succeeded = 0
    for trial in trials:
        failure = trial.result.top1_failure
        if failure is not None:
            counts[failure.step][str(failure.failure_type)] += 1
        elif trial.result.top1_success:
            succeeded += 1
        else:
            goal_not_met += 1
    steps = [
        {"step": i, "skill": s.skill, "robot": s.robot, "object": s.object, **counts[i]}
        for i, s in enumerate(skeleton)
    ]
    by_type = {t: sum(c[t] for c in counts) for t in FAILURE_TYPES}
    return {"steps": steps, "by_type": by_type, "goal_not_met": goal_not_met, "succeeded": succeeded}


def summarise(result: BenchResult) -> dict[str, Any]:
    """``{"tasks": {TASK: {METHOD: {top1, any5, trials, plan_seconds_median, failures}}}}``."""
    tasks: dict[str, Any] = {}
    for task in result.tasks:
        tasks[task] = {}
        for method in result.methods:
            trials = [t for t in result.trials if t.task == task and t.method == method]
            n = len(trials)
            if n == 0:
                continue  # a report of a partial log: a method not run on this task yet
            screened = [t for t in trials if t.passed_screen is not None]
            drawn = [t for t in trials if t.rounds is not None]
            tasks[task][method] = {
                "top1": sum(t.result.top1_success for t in trials) / n,
                "any5": sum(t.result.any_success for t in trials) / n,
                "trials": n,
                "plan_seconds_median": statistics.median(t.plan_seconds for t in trials),
                "failures": failure_table(task, trials),
                # Trials whose candidates all failed the screen (their top-1 is the method's own
                # best, unscreened), of those where the log says; None: it does not say.
                "screen_fallbacks": sum(t.passed_screen == 0 for t in screened) if screened else None,
                # Trials that drew more than one round of candidates (PlanSettings.rounds), of
                # those where the log says; None: it does not say (logs before session 29).
                "redrawn": sum(t.rounds is not None and t.rounds > 1 for t in drawn) if drawn else None,
            }
        if not tasks[task]:
            del tasks[task]  # a report of a partial log: a task not run yet
    return {"tasks": tasks}
