"""Two arms at once: steps of one ``group`` (lift and turn a pot with both hands).

Picks of a group approach in one 14-DoF plan, close their fingers and lift in the same physics
steps. Moves of a group that share a held object follow straight end-effector lines with one
shared clock, so the object the two hands hold is carried rigidly (the closed chain is kept);
moves with separate objects are planned together in 14-DoF joint space.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np

from gfc.geometry import FloatArray, invert, pose9_to_matrix
from gfc.plan.schema import Step
from gfc.sim.control import (
    cartesian_joint_path,
    close_grippers,
    execute_paths,
    gripper_target,
    interpolate_poses,
    waypoint_count,
)
from gfc.sim.ik import pose_error
from gfc.sim.motion import plan_motion
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.skills.motions import (
    APPROACH,
    LIFT,
    SkillContext,
    backed_off,
    check_grasp_on_object,
    collision_fn,
    ee,
    free_ik,
    free_ik_solutions,
    held_offset_error,
    joints,
    require_free,
    require_holding,
    translated,
)
from gfc.sim.skills.moving import hand_target
from gfc.sim.world import object_matrix

CHAIN_POSITION_TOLERANCE = 0.01  # m: how much the two grasps may disagree
CHAIN_ANGLE_TOLERANCE = math.radians(3.0)


def _together(
    ctx: SkillContext, robots: Sequence[str], targets: Sequence[FloatArray], what: str, speed: float
) -> None:
    """Straight end-effector lines for several robots on one clock (no collision planning)."""
    starts = [ee(ctx, r) for r in robots]
    count = max(waypoint_count(a, b) for a, b in zip(starts, targets, strict=True))
    paths = {}
    for r, a, b in zip(robots, starts, targets, strict=True):
        path = cartesian_joint_path(ctx.world, r, joints(ctx, r), interpolate_poses(a, b, count), ctx.rng)
        if path is None:
            raise SkillFailure(FailureType.METHOD, f"{r}: cannot follow a straight line to {what}")
        paths[r] = path
    execute_paths(ctx.world, paths, {r: gripper_target(ctx.world, r) for r in robots}, speed=speed)
    return None


def _plan_together(ctx: SkillContext, robots: Sequence[str], goals: Sequence[FloatArray], what: str) -> None:
    check = collision_fn(ctx, robots)
    start = np.concatenate([joints(ctx, r) for r in robots])
    goal = np.concatenate(list(goals))
    result = plan_motion(check, start, goal, ctx.rng)
    ctx.planning_s += result.planning_s
    if result.path is None:
        raise SkillFailure(
            FailureType.PATH,
            f"{' and '.join(robots)}: no collision-free path to {what}: {result.reason}",
        )
    paths = {r: [q[7 * k : 7 * k + 7] for q in result.path] for k, r in enumerate(robots)}
    execute_paths(ctx.world, paths, {r: gripper_target(ctx.world, r) for r in robots})


def _solo_goal(
    ctx: SkillContext,
    robot: str,
    pose: FloatArray,
    what: str,
    allowed: frozenset[tuple[str, str]] = frozenset(),
) -> FloatArray:
    return free_ik(ctx, robot, pose, collision_fn(ctx, [robot], allowed), what)


def _ignoring(ctx: SkillContext, robot: str, robots: Sequence[str]) -> frozenset[tuple[str, str]]:
    """Pairs that may touch when ``robot``'s goal is solved alone: it (and what it holds) with
    the other robots of its group (and what they hold)."""
    mine = {robot} | ({ctx.world.grasps[robot].object} if robot in ctx.world.grasps else set())
    theirs = {r for r in robots if r != robot}
    theirs |= {ctx.world.grasps[r].object for r in theirs if r in ctx.world.grasps}
    return frozenset((a, b) for a in mine for b in theirs)


def _free_pair(
    ctx: SkillContext, robots: Sequence[str], options: Sequence[Sequence[FloatArray]]
) -> list[FloatArray]:
    """The first combination of the arms' IK solutions (best first) that is free together."""
    check = collision_fn(ctx, robots)
    hit = None
    for combo in itertools.product(*options):
        hit = check(np.concatenate(combo))
        if hit is None:
            return list(combo)
    assert hit is not None
    raise SkillFailure(FailureType.PATH, f"the move targets collide: {hit.moving} with {hit.other}")


def group_pick(ctx: SkillContext, steps: Sequence[Step], actions: Sequence[FloatArray]) -> str:
    world = ctx.world
    robots = [s.robot for s in steps]
    grasps = []
    for s, a in zip(steps, actions, strict=True):
        assert s.object is not None
        require_free(world, s.robot)
        world_from_grasp = object_matrix(world.physics, s.object) @ pose9_to_matrix(a)
        check_grasp_on_object(world, s.object, world_from_grasp)
        grasps.append(world_from_grasp)
    pre = [backed_off(g, APPROACH) for g in grasps]
    goals = [_solo_goal(ctx, r, p, "its pre-grasp pose") for r, p in zip(robots, pre, strict=True)]
    _plan_together(ctx, robots, goals, "the pre-grasp poses")
    _together(ctx, robots, grasps, "the grasp poses", speed=0.5)
    objects = [s.object for s in steps if s.object is not None]
    z_before = {o: object_matrix(world.physics, o)[2, 3] for o in objects}
    made = close_grippers(world, list(zip(robots, objects, strict=True)))
    for r, o, g in zip(robots, objects, made, strict=True):
        if g is None:
            raise SkillFailure(FailureType.PHYSICS, f"{r}'s fingers closed without holding {o}")
    _together(
        ctx,
        robots,
        [translated(ee(ctx, r), [0.0, 0.0, LIFT]) for r in robots],
        "the lift",
        speed=0.3,
    )
    for o in set(objects):
        rise = object_matrix(world.physics, o)[2, 3] - z_before[o]
        if rise < 0.08:
            raise SkillFailure(
                FailureType.PHYSICS,
                f"{o} did not come up with the grippers (rose {rise * 100:.1f} cm)",
            )
    return f"{' and '.join(robots)} picked {' and '.join(sorted(set(objects)))} together"


def group_move(ctx: SkillContext, steps: Sequence[Step], actions: Sequence[FloatArray]) -> str:
    world = ctx.world
    robots = [s.robot for s in steps]
    targets = []
    for s, a in zip(steps, actions, strict=True):
        require_holding(world, s.robot, s.object)
        targets.append(hand_target(world, s.robot, s.object, a))
    held = [s.object for s in steps]
    if len(steps) == 2 and held[0] is not None and held[0] == held[1]:
        # One object in two hands: the hands must keep their relative pose (a closed chain).
        now = invert(ee(ctx, robots[0])) @ ee(ctx, robots[1])
        then = invert(targets[0]) @ targets[1]
        dp, da = pose_error(now, then)
        if dp > CHAIN_POSITION_TOLERANCE or da > CHAIN_ANGLE_TOLERANCE:
            raise SkillFailure(
                FailureType.METHOD,
                f"the targets would pull the hands {dp * 100:.1f} cm / "
                f"{math.degrees(da):.1f} deg apart "
                f"while both hold {held[0]} (fixed transform violated)",
            )
        check = collision_fn(ctx, robots)
        for r, t in zip(robots, targets, strict=True):
            # Each hand's target alone, with the other hand still where it is: the object they
            # share may touch that other hand (it is held there now, and the joint path below is
            # checked for both arms together).
            others = frozenset((held[0], o) for o in robots if o != r)
            _solo_goal(ctx, r, t, "the move target", others)  # type 1 when unreachable at all
        starts = [ee(ctx, r) for r in robots]
        count = max(waypoint_count(a, b) for a, b in zip(starts, targets, strict=True))
        lines = [interpolate_poses(a, b, count) for a, b in zip(starts, targets, strict=True)]
        paths = []
        for r, line in zip(robots, lines, strict=True):
            path = cartesian_joint_path(world, r, joints(ctx, r), line, ctx.rng)
            if path is None:
                raise SkillFailure(FailureType.METHOD, f"{r}: cannot carry {held[0]} along the straight line")
            paths.append(path)
        for k in range(count):
            hit = check(np.concatenate([p[k] for p in paths]))
            if hit is not None:
                raise SkillFailure(
                    FailureType.PATH, f"carrying {held[0]} hits: {hit.moving} with {hit.other}"
                )
        execute_paths(world, dict(zip(robots, paths, strict=True)), {r: 0.0 for r in robots}, speed=0.4)
    else:
        # The arms move at once, so each target is solved with the other arm ignored (it will
        # not stay where it is now); then the two goals are checked together, and the joint
        # path between is planned for both.
        options = [
            free_ik_solutions(ctx, r, t, collision_fn(ctx, [r], _ignoring(ctx, r, robots)), "the move target")
            for r, t in zip(robots, targets, strict=True)
        ]
        _plan_together(ctx, robots, _free_pair(ctx, robots, options), "the move targets")
    for r, t in zip(robots, targets, strict=True):
        dp, _ = pose_error(ee(ctx, r), t)
        if dp > 0.015:
            raise SkillFailure(FailureType.PHYSICS, f"{r} stopped {dp * 100:.1f} cm short (blocked)")
        if r in world.grasps and held_offset_error(ctx, r) > 0.02:
            raise SkillFailure(FailureType.PHYSICS, f"{world.grasps[r].object} slipped in {r}'s hand")
    return f"{' and '.join(robots)} moved together"


def execute_group(ctx: SkillContext, steps: Sequence[Step], actions: Sequence[FloatArray]) -> str:
    skills = {s.skill for s in steps}
    if skills == {"pick"}:
        return group_pick(ctx, steps, actions)
    if skills == {"move"}:
        return group_move(ctx, steps, actions)
    raise SkillFailure(
        FailureType.METHOD,
        f"a group of {' + '.join(s.skill for s in steps)} cannot run at once (groups are picks or moves)",
    )
