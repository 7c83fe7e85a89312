"""The planners the task benchmark compares; each turns a task instance into ranked candidates.

- ``gfc``: the composed planner (``gfc.planner.planner.plan_candidates``) on the compiled plan:
  every temporal factor, the compensation of shared nodes, the constraints and the goal as
  spatial factors; candidates ranked by the planner (spatial cost, lowest first).
- ``linear_chain``: a GSC-style forward chain. Our reading: the same skill models chained
  through the same shared node versions (the serialised skeleton: each step's effects are the
  next step's pre nodes, and the composition counts each shared node once), sampled jointly by
  the same sampler, but *without the plan's spatial factors*: no user constraints, no goal. That
  isolates what GFC adds over chaining, the spatial factors. The compiler's implied factors stay
  (the physics of a two-handed grip, a pour's upright start: what any planner of these skills
  must respect; until session 9 they were dropped too), and candidates are ranked by their cost;
  a plan without any comes in sampling order (which is random).
- ``independent``: every step's skill model sampled on its own, conditioned only on what is
  observed: each temporal factor gets private copies of its free node versions, so no node links
  two factors; observed (initial-scene) nodes stay exact conditioning inputs. A step whose pre
  nodes are observed is thus sampled from ``p(action, effects | observed scene)``; a later step
  from its model's own prior over its pre nodes. It runs through the same sampler as ``gfc`` on
  this decoupled graph (no shared nodes, so no compensation; no spatial factors). Candidates come
  in sampling order.
- ``random``: uniform actions per step (``gfc.bench.uniform``), no models.
- ``reference`` (opt-in, not a planner): the task's hand-written reference actions as the only
  candidate, repeated. An oracle that shows what the simulator allows on the benchmark's scenes
  and checks the harness's success path; never part of the default comparison.

Every method's candidates (not the oracle's) then pass the same kinematic screen
(``gfc.sim.screen``, ``PlanSettings.screen``): the first candidates whose poses the arms can
reach without collision move to the front, so top-1 executes the best candidate that is
kinematically possible. The screen knows nothing of the task's goal or constraints.

Planning time is the CPU time of the method's whole call (``time.process_time``: with one torch
thread, the wall clock on an idle core; the benchmark executes simulations alongside, which would
inflate a wall clock), including loading models into a bank (the libraries cache banks, so only a
task's first trial pays for it; the median hides that).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np

from gfc.bench.uniform import random_actions
from gfc.geometry import FloatArray
from gfc.plan.compiler import compile_plan
from gfc.plan.graph import CompiledPlan, FactorToken, NodeVersion, TemporalFactor
from gfc.plan.schema import Options
from gfc.planner.library import SkillLibrary
from gfc.planner.planner import PlanResult, plan_candidates
from gfc.sim.screen import screen_order
from gfc.tasks.base import TaskInstance

Actions = list[FloatArray | None]
METHODS = ("gfc", "independent", "linear_chain", "random")  # the default comparison
ORACLES = ("reference",)


class MissingModelsError(LookupError):
    """A method needs skill models the library does not have (or cannot load)."""

    def __init__(self, missing: dict[str, str]) -> None:
        self.missing = missing  # model key -> what the library said
        keys = ", ".join(sorted(missing))
        details = "; ".join(f"{k}: {v}" for k, v in sorted(missing.items()))
        super().__init__(f"missing skill models: {keys} ({details})")

    def __str__(self) -> str:
        return str(self.args[0])


@dataclass(frozen=True)
class MethodPlan:
    """Candidates for one task instance, best first, and how long planning took."""

    candidates: list[Actions]
    seconds: float
    # Candidates that passed the kinematic screen (screening stops at SCREEN_KEEP passes), or
    # None when they were not screened. 0: every candidate was refused, and the ones executed
    # are the method's own best, unscreened (a fallback).
    passed_screen: int | None = None
    rounds: int = 1  # sampling rounds drawn (PlanSettings.rounds); passed_screen counts the last


@dataclass(frozen=True)
class PlanSettings:
    candidates: int = 10  # sampled per trial; all of them are ranked, the first five are executed
    steps: int = 50  # reverse diffusion steps
    # Kinematic screening (gfc.sim.screen): candidates whose poses the arms cannot reach go to
    # the back of the ranking. Applied to every method alike (not the reference oracle).
    screen: bool = True
    # Sampling rounds: while no candidate drawn so far passed the screen, the method draws
    # ``candidates`` more (a fresh seed), up to this many rounds in all; 1: one draw. Session 29:
    # in 18 of 80 Hammer Nail scenes none of 128 GFC candidates passed, and 8 of 8 such scenes
    # probed had one within two more rounds of 128.
    rounds: int = 1


SCREEN_KEEP = 5  # screening stops once this many candidates have passed (any-5 runs five)


def required_models(compiled: CompiledPlan) -> list[str]:
    """The model keys (references without version) the learned methods need for a plan."""
    return sorted({f.model.split("@")[0] for f in compiled.temporal})


def check_models(library: SkillLibrary, refs: Sequence[str]) -> None:
    """Raise ``MissingModelsError`` naming every reference the library cannot provide.

    The library protocol does not fix its error types (a ``KeyError`` in memory, the skill
    store's own errors on disk), so any failure to build a one-model bank counts as missing, with
    the library's message kept next to the key.
    """
    missing: dict[str, str] = {}
    for ref in sorted(set(refs)):
        try:
            library.bank([ref])
        except Exception as exc:
            # KeyError's str() quotes its message; the message itself reads better.
            text = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
            missing[ref] = str(text) or type(exc).__name__
    if missing:
        raise MissingModelsError(missing)


def decouple(plan: CompiledPlan) -> CompiledPlan:
    """The plan with no free node shared between temporal factors and no spatial factors.

    Known (observed) nodes keep their place and values; each factor's free tokens point to fresh
    node versions of their own (entity ``name~sSTEP``, so labels stay unique). Node ids are
    positions in ``nodes``, as the planner expects.
    """
    nodes: list[NodeVersion] = []
    known_id: dict[int, int] = {}
    for node in plan.known:
        known_id[node.id] = len(nodes)
        nodes.append(replace(node, id=len(nodes)))
    temporal: list[TemporalFactor] = []
    for factor in plan.temporal:
        tokens: list[FactorToken] = []
        for token in factor.tokens:
            if token.node is None:
                tokens.append(token)
                continue
            node = plan.nodes[token.node]
            if node.known:
                tokens.append(replace(token, node=known_id[node.id]))
                continue
            copy = replace(node, id=len(nodes), entity=f"{node.entity}~s{factor.step}", written_by=())
            nodes.append(copy)
            tokens.append(replace(token, node=copy.id))
        temporal.append(replace(factor, tokens=tuple(tokens)))
    return replace(plan, nodes=tuple(nodes), temporal=tuple(temporal), spatial=())


def chain_only(plan: CompiledPlan) -> CompiledPlan:
    """The plan's temporal chain: the plan's constraints and goal dropped. Implied factors stay:
    they are not the user's spatial knowledge but what any planner of these skills must respect
    (two hands on one pot keep their relative pose; a pour starts upright, a precondition no plan
    should have to state; docs/adr/0005). The pour's learned pre-state model is a temporal factor
    and stays too: chaining uses every skill's model."""
    return replace(plan, spatial=tuple(f for f in plan.spatial if f.source == "implied"))


def candidate_actions(result: PlanResult, n_steps: int) -> list[Actions]:
    """The planner's ranked candidates as one action list per candidate, in skeleton order."""
    out: list[Actions] = []
    for candidate in result.candidates:
        actions: Actions = [None] * n_steps
        for entry in candidate["steps"]:
            values = entry["action"]
            actions[entry["step"]] = np.asarray(values, dtype=np.float64) if values else None
        out.append(actions)
    return out


class Method(Protocol):
    """A planner: ranked candidates for a task instance. ``batch`` numbers the draw (sampling
    round): each batch draws from its own random stream, batch 0 from the plan's own seed."""

    def __call__(self, instance: TaskInstance, settings: PlanSettings, batch: int = 0) -> MethodPlan: ...


def batch_seed(seed: int, batch: int) -> int:
    """The sampler seed of draw ``batch`` of a plan seeded ``seed``: batch 0 is the plan's own
    seed, so one round draws exactly what the planner draws alone; a later batch a seed mixed from
    both (torch seeds its CPU generator from the low 32 bits only, so an offset of 2**32, tried
    first, drew the very same candidates again)."""
    if batch == 0:
        return seed
    return int(np.random.SeedSequence([seed, batch]).generate_state(1)[0])


def _sampled(transform: Callable[[CompiledPlan], CompiledPlan], library: SkillLibrary) -> Method:
    def plan(instance: TaskInstance, settings: PlanSettings, batch: int = 0) -> MethodPlan:
        t0 = time.process_time()
        compiled = transform(compile_plan(instance.plan))
        options = Options(
            candidates=settings.candidates,
            top_k=settings.candidates,
            steps=settings.steps,
            seed=batch_seed(instance.plan.options.seed, batch),
            sampler=instance.plan.options.sampler,
            compensation=instance.plan.options.compensation,
            corrector_steps=instance.plan.options.corrector_steps,
        )
        result = plan_candidates(compiled, library, options)
        candidates = candidate_actions(result, len(instance.plan.skeleton))
        return MethodPlan(candidates, time.process_time() - t0)

    return plan


def _random(instance: TaskInstance, settings: PlanSettings, batch: int = 0) -> MethodPlan:
    t0 = time.process_time()
    # Its own stream per instance and batch, apart from the scene's: the same scene gets the same
    # draws (batch 0's stream is the one of logs before batches existed).
    rng = np.random.default_rng([instance.seed, 7] if batch == 0 else [instance.seed, 7, batch])
    candidates = [random_actions(instance.plan, rng) for _ in range(settings.candidates)]
    return MethodPlan(candidates, time.process_time() - t0)


def _reference(instance: TaskInstance, settings: PlanSettings, batch: int = 0) -> MethodPlan:
    t0 = time.process_time()
    candidates = [list(instance.reference_actions) for _ in range(settings.candidates)]
    return MethodPlan(candidates, time.process_time() - t0)


def screened(method: Method) -> Method:
    """``method`` with its candidates re-ranked by the kinematic screen when settings ask for it:
    those that pass first, each group in the method's own order. Its time counts as planning.

    With ``settings.rounds`` > 1, a draw none of whose candidates passes is followed by another
    (``batch`` 1, 2, ...) until one passes or the rounds are spent: the passed ones of the last
    draw first, then the rest of it, then the earlier draws in order. When no draw passes, the
    first draw's candidates come first, in the method's own order, as with one round."""

    def plan(instance: TaskInstance, settings: PlanSettings, batch: int = 0) -> MethodPlan:
        result = method(instance, settings, batch)
        if not settings.screen:
            return result
        seconds = result.seconds
        refused: list[Actions] = []  # the earlier draws' candidates, none of which passed
        for draw in range(settings.rounds):
            if draw > 0:
                result = method(instance, settings, batch + draw)
                seconds += result.seconds
            t0 = time.process_time()
            order, verdicts = screen_order(
                instance.plan, result.candidates, keep=SCREEN_KEEP, seed=instance.seed
            )
            seconds += time.process_time() - t0
            passed = sum(v is not None and v.feasible for v in verdicts)
            if passed:
                candidates = [result.candidates[k] for k in order] + refused
                return MethodPlan(candidates, seconds, passed, draw + 1)
            refused += result.candidates
        return MethodPlan(refused, seconds, 0, settings.rounds)

    return plan


def make_method(name: str, library: SkillLibrary | None) -> Method:
    """The planner called ``name``; the learned ones need a library."""
    if name == "random":
        return screened(_random)
    if name == "reference":
        return _reference
    if name not in METHODS:
        raise KeyError(f"unknown method {name!r} (known: {', '.join(METHODS + ORACLES)})")
    if library is None:
        raise ValueError(f"method {name!r} needs a skill library")
    transform = {"gfc": lambda p: p, "linear_chain": chain_only, "independent": decouple}[name]
    return screened(_sampled(transform, library))


def needs_models(name: str) -> bool:
    return name not in ("random", *ORACLES)
