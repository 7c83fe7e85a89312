"""Try one skill model's skill in the simulator: set-up, target stage, transition rows.

An *attempt* samples a scenario (``gfc.data.scenarios``), builds a fresh world, runs the set-up
steps with their heuristic actions, reads the state the set-up left, draws the target stage's
actions from a *source* (the collection prior, uniform random actions, or a trained model: the
last two are what ``gfc skills check`` compares), executes the stage and, on success, returns
one transition row per target step: (pre nodes, action, effect nodes) in the acting robot's base
frame, the token order of ``SkillSpec.tokens``. A failed set-up is reported as such and never
counted against the skill. Attempts are pure functions of their fields (pool-safe, seeded).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
import torch

from gfc.data.scenarios import Scenario, State, scenario_for
from gfc.geometry import FloatArray, pose7_to_matrix, pose7_to_pose9, pose9_frame_map, yaw_quat
from gfc.plan.schema import PlanRequest, Step
from gfc.skills.signatures import skill_spec

SETUP_FAILED = "setup"
PRE_STATE_DRAWS = 16  # pre-state samples drawn at most for a check until one suits its scene
Source = Literal["prior", "uniform", "model"]


@dataclass(frozen=True)
class Prior:
    """How the collection draws target actions: the scenario's heuristic (with its noise), or,
    for ``uniform_share`` of the attempts, uniformly random actions."""

    uniform_share: float = 0.1


@dataclass(frozen=True)
class Attempt:
    model: str  # skill model key, e.g. place.hammer.box
    seed: int
    source: Source = "prior"
    prior: Prior = field(default_factory=Prior)
    store: str | None = None  # for source="model": skill store location
    ref: str | None = None  # for source="model": model reference (name or name@version)


def world_state(poses: dict[str, list[float]], grippers: dict[str, float]) -> State:
    return {"poses": poses, "grippers": grippers}


def robot_frame_map(plan: PlanRequest, robot: str) -> tuple[FloatArray, FloatArray]:
    spec = next(r for r in plan.scene.robots if r.name == robot)
    return pose9_frame_map(pose7_to_matrix([*spec.base, *yaw_quat(spec.yaw)]))


def node(plan: PlanRequest, step: Step, entity: str, state: State) -> FloatArray:
    """One node as the step's model sees it: a 9-D pose in the acting robot's base frame, plus
    the gripper opening for robots."""
    a, b = robot_frame_map(plan, step.robot)
    pose = a @ pose7_to_pose9(state["poses"][entity]) + b
    robots = {r.name for r in plan.scene.robots}
    return np.concatenate([pose, [state["grippers"][entity]]]) if entity in robots else pose


def role_entity(step: Step, role: str) -> str:
    entity = {"robot": step.robot, "object": step.object, "target": step.target, "from": step.from_}[role]
    assert entity is not None, f"step {step.skill} has no {role}"
    return entity


def pre_nodes(plan: PlanRequest, step: Step, before: State) -> FloatArray:
    spec = skill_spec(step.skill)
    reads = [r for r in spec.reads if step.object is not None or r != "object"]
    return np.concatenate([node(plan, step, role_entity(step, r), before) for r in reads])


def transition_row(
    plan: PlanRequest, step: Step, action: FloatArray, before: State, after: State
) -> FloatArray:
    """(pre nodes, action, effect nodes) of one step, flat, in the acting robot's base frame."""
    spec = skill_spec(step.skill)
    writes = [r for r in spec.writes if step.object is not None or r != "object"]
    effect = [node(plan, step, role_entity(step, r), after) for r in writes]
    return np.concatenate([pre_nodes(plan, step, before), np.asarray(action, dtype=np.float64), *effect])


def stage_plan(plan: PlanRequest, steps: slice) -> PlanRequest:
    return plan.model_copy(update={"skeleton": plan.skeleton[steps], "goal": []})


ActionSource = Callable[[Scenario, State, np.random.Generator], list[FloatArray]]


def prior_source(prior: Prior) -> ActionSource:
    def draw(scenario: Scenario, before: State, rng: np.random.Generator) -> list[FloatArray]:
        if rng.uniform() < prior.uniform_share:
            return scenario.uniform(rng, before)
        return scenario.propose(rng, before)

    return draw


def uniform_source(scenario: Scenario, before: State, rng: np.random.Generator) -> list[FloatArray]:
    return scenario.uniform(rng, before)


def action_source(attempt: Attempt) -> ActionSource:
    if attempt.source == "prior":
        return prior_source(attempt.prior)
    if attempt.source == "uniform":
        return uniform_source
    from gfc.skills.check import model_source  # torch model loading only where it is needed

    assert attempt.store is not None and attempt.ref is not None, "source='model' needs store and ref"
    return model_source(attempt.store, attempt.ref)


# Worlds kept between attempts of this worker process (see gfc.sim.reuse): building one loads
# four robot models, a quarter of an attempt's time. Created on first use, in the worker.
_worlds: Any = None


def _world_cache() -> Any:
    global _worlds
    if _worlds is None:
        from gfc.sim.reuse import WorldCache

        _worlds = WorldCache()
    return _worlds


def run_attempt(attempt: Attempt) -> dict[str, Any]:
    """One scenario, executed: ``status`` is ``success`` (with ``rows``), ``failure`` (with the
    type and reason) or ``setup`` (the set-up failed; not the skill's fault)."""
    from gfc.sim.execute import execute_in_world
    from gfc.sim.world import entity_poses, gripper_openings

    rng = np.random.default_rng(attempt.seed)
    scenario = scenario_for(attempt.model)(rng)
    if scenario.kinematic:
        return run_kinematic(scenario, attempt.seed, _sampled_setup(attempt, scenario, rng))
    plan, k = scenario.plan, scenario.n_setup
    worlds = _world_cache()
    world = worlds.acquire(plan.scene, scenario.contents)
    healthy = False
    try:
        if k:
            setup = execute_in_world(
                world, stage_plan(plan, slice(0, k)), scenario.setup_actions, attempt.seed
            )
            failed = next((s for s in setup.steps if not s.success), None)
            if failed is not None or len(setup.steps) < k:
                healthy = True
                return {"status": SETUP_FAILED, "reason": failed.reason if failed else "set-up incomplete"}
            before = world_state(setup.steps[-1].poses, setup.steps[-1].grippers)
        else:
            before = world_state(entity_poses(world), gripper_openings(world))
        actions = action_source(attempt)(scenario, before, rng)
        target = stage_plan(plan, slice(k, None))
        outcome = execute_in_world(world, target, actions, attempt.seed + 1)
        healthy = True
    finally:
        worlds.release(world, plan.scene, reusable=healthy)
    last = outcome.steps[-1] if outcome.steps else None
    if last is None or not all(s.success for s in outcome.steps):
        failed = next((s for s in outcome.steps if not s.success), last)
        return {
            "status": "failure",
            "failure_type": failed.failure_type if failed else None,
            "reason": failed.reason if failed else "no step ran",
            "actions": [[float(v) for v in a] for a in actions],
        }
    after = world_state(last.poses, last.grippers)
    rows = [
        transition_row(plan, step, a, before, after) for step, a in zip(target.skeleton, actions, strict=True)
    ]
    return {"status": "success", "rows": [[float(v) for v in row] for row in rows]}


def run_kinematic(
    scenario: Scenario, seed: int, setup_actions: list[FloatArray | None] | None = None
) -> dict[str, Any]:
    """A terminal skill's pre-state labelled by the kinematic screen (``Scenario.kinematic``):
    the set-up walked on the planning mirror (nothing moves by physics), then the target stage's
    precondition; on a pass, one row of pre nodes per target step from where the walk left the
    objects and hands. Fails as the screen does (its reason), counted against the skill.
    ``setup_actions``: instead of the scenario's own (a model's pre-state realised as set-up)."""
    from gfc.geometry import matrix_to_pose7
    from gfc.sim.screen import Screen

    plan, k = scenario.plan, scenario.n_setup
    target = stage_plan(plan, slice(k, None))
    if any(skill_spec(s.skill).action_dim for s in target.skeleton):
        raise ValueError("kinematic labels are for action-less target steps (strike, pour)")
    setup = scenario.setup_actions if setup_actions is None else setup_actions
    with Screen(plan, seed) as screen:
        walk = screen.walk([*setup, *([None] * scenario.n_target)])
    if not walk.verdict.feasible:
        return {
            "status": "failure",
            "failure_type": "kinematic",
            "reason": walk.verdict.reason,
            "actions": [],
        }
    poses = {name: [float(v) for v in matrix_to_pose7(m)] for name, m in walk.poses.items()}
    state = world_state(poses, walk.openings)
    rows = [pre_nodes(plan, step, state) for step in target.skeleton]
    return {"status": "success", "rows": [[float(v) for v in row] for row in rows]}


def _sampled_setup(
    attempt: Attempt, scenario: Scenario, rng: np.random.Generator
) -> list[FloatArray | None] | None:
    """For ``source="model"`` on a kinematic scenario: the model's pre-state (sampled with
    nothing given) as the set-up that would reach it; else None (the scenario's own set-up,
    which for "uniform" is its random meeting: a pre-state model has no action to randomise)."""
    if attempt.source != "model":
        return None
    from gfc.skills.check import load_model, realise_pre_state, sample_pre_state

    assert attempt.store is not None and attempt.ref is not None, "source='model' needs store and ref"
    # Nothing of a pre-state is observed, and the data holds both arms as pourer (the target on
    # the pourer's inward side: -y for the left arm): draw until the sample is for this pourer.
    pourer = scenario.plan.skeleton[scenario.n_setup].robot
    inward = -1.0 if next(r for r in scenario.plan.scene.robots if r.name == pourer).base[1] > 0 else 1.0
    model = load_model(attempt.store, attempt.ref)
    for _ in range(PRE_STATE_DRAWS):
        row = sample_pre_state(model, int(rng.integers(2**31)))
        if row[20] * inward > 0:  # the target's y in the pourer's base frame
            break
    return realise_pre_state(scenario, row)


@dataclass(frozen=True)
class Summary:
    rows: torch.Tensor  # (R, D) transition rows of the successes
    attempts: int  # attempts whose set-up succeeded (the skill was really tried)
    successes: int
    failures: dict[str, int]  # failure type -> count; "setup" for failed set-ups

    @property
    def success_rate(self) -> float:
        return self.successes / self.attempts if self.attempts else 0.0


def summarise(results: list[dict[str, Any]], width: int) -> Summary:
    rows = [row for r in results if r["status"] == "success" for row in r["rows"]]
    failures = Counter(str(r["failure_type"]) for r in results if r["status"] == "failure")
    setups = sum(r["status"] == SETUP_FAILED for r in results)
    if setups:
        failures[SETUP_FAILED] = setups
    tried = len(results) - setups
    data = torch.tensor(rows, dtype=torch.float32).reshape(-1, width)
    return Summary(data, tried, sum(r["status"] == "success" for r in results), dict(failures))


def attempts_for(model: str, seeds: range, source: Source = "prior", **fields: Any) -> list[Attempt]:
    base = Attempt(model, 0, source, **fields)
    return [replace(base, seed=s) for s in seeds]
