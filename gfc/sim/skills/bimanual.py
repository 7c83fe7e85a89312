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
from gfc.sim.collision import Collision, CollisionFn
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
CARRY_SPEED = 0.4  # rad/s of the fastest joint when carrying along straight lines


def _together(
    ctx: SkillContext, robots: Sequence[str], targets: Sequence[FloatArray], what: str, speed: float
) -> None:
    """Straight end-effector lines for several robots on one clock (no collision planning)."""
    paths = _straight_lines(ctx, robots, targets, what, collide=False)
    execute_paths(ctx.world, paths, {r: gripper_target(ctx.world, r) for r in robots}, speed=speed)


def _straight_lines(
    ctx: SkillContext, robots: Sequence[str], targets: Sequence[FloatArray], what: str, collide: bool = True
) -> dict[str, list[FloatArray]]:
    """Joint paths that move every hand along a straight line to its target (``what``) on one
    clock: type 1 when a line cannot be tracked; with ``collide``, type 2 when the arms or what
    they hold would hit something on the way."""
    starts = [ee(ctx, r) for r in robots]
    count = max(waypoint_count(a, b) for a, b in zip(starts, targets, strict=True))
    paths = {}
    for r, a, b in zip(robots, starts, targets, strict=True):
        path = cartesian_joint_path(ctx.world, r, joints(ctx, r), interpolate_poses(a, b, count), ctx.rng)
        if path is None:
            raise SkillFailure(FailureType.METHOD, f"{r}: cannot follow a straight line to {what}")
        paths[r] = path
    if collide:
        check = collision_fn(ctx, robots)
        for k in range(count):
            hit = check(np.concatenate([paths[r][k] for r in robots]))
            if hit is not None:
                raise SkillFailure(FailureType.PATH, f"on the way to {what}: {hit.moving} hits {hit.other}")
    return paths


def _plan_in_turn(
    ctx: SkillContext, robots: Sequence[str], goals: Sequence[FloatArray]
) -> list[tuple[str, list[FloatArray]]] | None:
    """Each arm's path planned alone, one arm after the other (the other parked where it is, or
    at its goal once it has moved), in either order; ``None`` when neither order works.

    Used when a held container must stay upright: that constraint thins the free space, and
    two 7-DoF queries find paths through it far more often than one 14-DoF query (measured on
    the Pour Cup reference: 14-DoF planning failed 4 of 5 carries in 5 s)."""
    both = collision_fn(ctx, robots)
    now = {r: joints(ctx, r) for r in robots}
    goal = dict(zip(robots, goals, strict=True))
    for order in (list(robots), list(robots)[::-1]):
        plans = []
        for k, r in enumerate(order):
            check = collision_fn(ctx, [r])
            parked = {o: goal[o] if o in order[:k] else now[o] for o in robots}
            both(np.concatenate([parked[o] for o in robots]))  # poses the mirror; the verdict is not needed
            result = plan_motion(check, now[r], goal[r], ctx.rng)
            ctx.planning_s += result.planning_s
            if result.path is None:
                break
            plans.append((r, result.path))
        else:
            return plans
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
    ctx: SkillContext,
    robots: Sequence[str],
    targets: Sequence[FloatArray],
    options: Sequence[Sequence[FloatArray]],
) -> list[FloatArray]:
    """The first combination of the arms' IK solutions (best first) that is free together.

    Each arm's options were solved with the other arms ignored, mostly from the same seeds, so
    they often lie on one branch; when every combination collides, each arm's goal is solved
    again with the other arm fixed at one of its options (``_solve_beside``)."""
    check = collision_fn(ctx, robots)
    hit = None
    for combo in itertools.product(*options):
        hit = check(np.concatenate(combo))
        if hit is None:
            return list(combo)
    assert hit is not None
    beside = _solve_beside(ctx, robots, targets, options, check) if len(robots) == 2 else None
    if beside is not None:
        return beside
    raise SkillFailure(FailureType.PATH, f"the move targets collide: {hit.moving} with {hit.other}")


BESIDE_OPTIONS = 2  # of the fixed arm's options, the best few are tried


def _solve_beside(
    ctx: SkillContext,
    robots: Sequence[str],
    targets: Sequence[FloatArray],
    options: Sequence[Sequence[FloatArray]],
    both: CollisionFn,
) -> list[FloatArray] | None:
    """Two arms' goals free together: one arm at one of its options, the other's goal solved
    with it in place (random starts included); ``None`` when no such pair is found. Measured on
    Pour Cup: 3 of 10 top-1 failures at 509f496 were pairs of move targets the screen had found
    free together while every pair of the executor's options collided (s17, ADR 0012)."""
    for fixed in (0, 1):
        solved = 1 - fixed
        for q_fixed in options[fixed][:BESIDE_OPTIONS]:

            def check(q: FloatArray, q_fixed: FloatArray = q_fixed, solved: int = solved) -> Collision | None:
                pair = [q_fixed, q] if solved == 1 else [q, q_fixed]
                return both(np.concatenate(pair))

            try:
                found = free_ik_solutions(ctx, robots[solved], targets[solved], check, "the move target")
            except SkillFailure:
                continue
            return [q_fixed, found[0]] if solved == 1 else [found[0], q_fixed]
    return None


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
        for r, t in zip(robots, targets, strict=True):
            # Each hand's target alone, with the other hand still where it is: the object they
            # share may touch that other hand (it is held there now, and the joint path below is
            # checked for both arms together).
            others = frozenset((held[0], o) for o in robots if o != r)
            _solo_goal(ctx, r, t, "the move target", others)  # type 1 when unreachable at all
        paths = _straight_lines(ctx, robots, targets, "the move targets")
        execute_paths(world, paths, {r: 0.0 for r in robots}, speed=CARRY_SPEED)
    else:
        # A container with contents is carried upright: straight end-effector lines keep its
        # orientation (both ends are upright, so the slerp between them only turns about the
        # vertical), where a joint-space path would tilt it and spill what it holds.
        # Otherwise, or when the lines are blocked, the arms move at once, so each target is
        # solved with the other arm ignored (it will not stay where it is now); then the two
        # goals are checked together, and the joint path between is planned for both.
        upright = any(world.contents.get(o, 0) > 0 for o in held if o is not None)
        lines = None
        if upright:
            try:
                lines = _straight_lines(ctx, robots, targets, "the move targets")
            except SkillFailure as blocked:
                ctx.notes.append(f"no upright carry ({blocked.reason}); planned in joint space")
        fingers = {r: gripper_target(world, r) for r in robots}
        if lines is not None:
            execute_paths(world, lines, fingers, speed=CARRY_SPEED)
        else:
            options = [
                free_ik_solutions(
                    ctx, r, t, collision_fn(ctx, [r], _ignoring(ctx, r, robots)), "the move target"
                )
                for r, t in zip(robots, targets, strict=True)
            ]
            goals = _free_pair(ctx, robots, targets, options)
            in_turn = _plan_in_turn(ctx, robots, goals) if upright else None
            if in_turn is None:
                _plan_together(ctx, robots, goals, "the move targets")
            for r, path in in_turn or []:
                execute_paths(world, {r: path}, {r: fingers[r]}, speed=CARRY_SPEED)
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
