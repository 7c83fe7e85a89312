"""Execute a plan's skeleton in the simulator, step by step (groups together), and report."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from tqdm import tqdm

from gfc.geometry import FloatArray
from gfc.plan.schema import PlanRequest, Step
from gfc.sim.goals import goal_satisfied
from gfc.sim.outcome import FailureType, PlanOutcome, SkillFailure, StepOutcome, StepTimings
from gfc.sim.skills.bimanual import execute_group
from gfc.sim.skills.grasping import pick, regrasp
from gfc.sim.skills.motions import SkillContext
from gfc.sim.skills.moving import move
from gfc.sim.skills.placing import place
from gfc.sim.skills.terminal import pour, strike
from gfc.sim.skills.tools import pull, push
from gfc.sim.world import World, build_world, entity_poses, gripper_openings
from gfc.skills.signatures import skill_spec

Executor = Callable[[SkillContext, Step, FloatArray], str]
EXECUTORS: dict[str, Executor] = {
    "pick": pick,
    "place": place,
    "move": move,
    "regrasp": regrasp,
    "push": push,
    "pull": pull,
    "strike": strike,
    "pour": pour,
}
Frame = Callable[[World, str], None]  # called after each stage with a caption (key frames)


def default_contents(plan: PlanRequest, beads: int = 6) -> dict[str, int]:
    """What the poured containers hold: ``beads`` beads in each source of a ``pour`` step."""
    return {s.object: beads for s in plan.skeleton if s.skill == "pour" and s.object is not None}


def stages(plan: PlanRequest) -> list[list[int]]:
    """Step indices grouped into stages: adjacent steps sharing a ``group`` run together."""
    out: list[list[int]] = []
    for i, step in enumerate(plan.skeleton):
        if out and step.group is not None and plan.skeleton[out[-1][0]].group == step.group:
            out[-1].append(i)
        else:
            out.append([i])
    return out


def _check_action(i: int, step: Step, action: FloatArray | None) -> FloatArray:
    spec = skill_spec(step.skill)
    values = np.zeros(0) if action is None else np.asarray(action, dtype=np.float64).reshape(-1)
    if values.shape[0] != spec.action_dim or not np.all(np.isfinite(values)):
        raise SkillFailure(
            FailureType.METHOD,
            f"step {i} ({step.skill}) needs {spec.action_dim} finite action values, got {values.shape[0]}",
        )
    return values


def _run_stage(
    ctx: SkillContext, plan: PlanRequest, stage: list[int], actions: Sequence[FloatArray | None]
) -> str:
    steps = [plan.skeleton[i] for i in stage]
    values = [_check_action(i, plan.skeleton[i], actions[i]) for i in stage]
    if len(stage) == 1:
        return EXECUTORS[steps[0].skill](ctx, steps[0], values[0])
    return execute_group(ctx, steps, values)


def execute_in_world(
    world: World,
    plan: PlanRequest,
    actions: Sequence[FloatArray | None],
    seed: int,
    on_stage: Frame | None = None,
    progress: bool = False,
) -> PlanOutcome:
    """Execute ``actions`` (one per skeleton step; ``None`` or empty for strike/pour) in ``world``.

    Stops at the first failed stage; the remaining steps are not reported. Deterministic for a
    given world, plan, actions and seed.
    """
    if len(actions) != len(plan.skeleton):
        raise ValueError(f"{len(actions)} actions for {len(plan.skeleton)} skeleton steps")
    began = time.perf_counter()
    rng = np.random.default_rng(seed)
    outcomes: list[StepOutcome] = []
    for stage in tqdm(stages(plan), desc="stages", disable=not progress, leave=False):
        ctx = SkillContext(world, rng)
        t0, steps0 = time.perf_counter(), world.physics_steps
        failure: SkillFailure | None = None
        try:
            reason = _run_stage(ctx, plan, stage, actions)
        except SkillFailure as exc:
            failure, reason = exc, exc.reason
        timings = StepTimings(
            wall_s=(time.perf_counter() - t0) / len(stage),
            planning_s=ctx.planning_s / len(stage),
            physics_steps=(world.physics_steps - steps0) // len(stage),
        )
        poses, grippers = entity_poses(world), gripper_openings(world)
        for i in stage:
            outcomes.append(
                StepOutcome(
                    step=i,
                    skill=plan.skeleton[i].skill,
                    robot=plan.skeleton[i].robot,
                    success=failure is None,
                    failure_type=None if failure is None else int(failure.failure_type),
                    reason=reason,
                    poses=poses,
                    grippers=grippers,
                    timings=timings,
                )
            )
        if on_stage is not None:
            label = " + ".join(
                f"{plan.skeleton[i].skill} {plan.skeleton[i].object or ''}".strip() for i in stage
            )
            on_stage(
                world,
                f"{stage[0]}: {label}" + ("" if failure is None else f" FAILED ({failure.failure_type})"),
            )
        if failure is not None:
            break
    holds, report = goal_satisfied(world, plan.goal)
    return PlanOutcome(outcomes, holds, report, time.perf_counter() - began, world.physics_steps)


def execute_plan(
    plan: PlanRequest,
    actions: Sequence[FloatArray | None],
    seed: int = 0,
    contents: Mapping[str, int] | None = None,
    on_stage: Frame | None = None,
) -> PlanOutcome:
    """Build the plan's scene, execute the actions, close the world, return the outcome."""
    with build_world(plan.scene, default_contents(plan) if contents is None else contents) as world:
        if on_stage is not None:
            on_stage(world, "start")
        return execute_in_world(world, plan, actions, seed, on_stage)
