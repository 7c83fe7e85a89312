"""Motion building blocks shared by the skill executors: reach a pose collision-free, move in a
straight line, and the geometric checks that turn into failure type 1."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np

from gfc.geometry import FloatArray, invert
from gfc.kinds import object_kind
from gfc.sim.collision import (
    FINGER_LANDING,
    UPRIGHT_TILT,
    Carried,
    CollisionFn,
    finger_depth,
    make_collision_fn,
    self_collision_fn,
)
from gfc.sim.control import (
    cartesian_joint_path,
    execute_paths,
    gripper_target,
    interpolate_poses,
    tracks_lines,
    waypoint_count,
)
from gfc.sim.ik import solve_ik
from gfc.sim.motion import plan_motion
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.panda import (
    FINGER_MAX,
    HOME_JOINTS,
    LOWER_LIMITS,
    UPPER_LIMITS,
    arm_joints,
    ee_matrix,
    set_joints,
)
from gfc.sim.world import World, gripper_openings, object_matrix, sync_mirror
from gfc.skills.signatures import PICK_LIFT

APPROACH = 0.10  # m: pre-grasp offset back along the gripper's approach axis
LIFT = PICK_LIFT  # m: how far a pick lifts the object
IK_ATTEMPTS = 24
LEAN_MARGIN = math.radians(5.0)  # rad a leaning container may tilt further while carried
# m a carried object keeps from everything on a planned motion (reach): the executed path runs
# a few millimetres off the planned one. Without it, a direct path to above the box sagged to
# 7 mm over the box's wall and caught the carried block on it (Rearrangement Push T3, seed 4).
CARRIED_CLEARANCE = 0.01
# m the open hand keeps from objects on a planned motion (reach). The collision test lets links
# sink 2 mm into things (resting contact), so a path to the nail's pre-grasp could sweep a
# finger 1.5 mm into the nail: executed, the finger knocked it 2.5 cm aside and the fingers then
# closed on nothing (Hammer Nail seeds 21 and 48, docs/bench/trials/bimanual_s28_hammer_nail.jsonl).
HAND_CLEARANCE = 0.01
DOWN_COS = math.cos(math.radians(30.0))  # hands this close to straight down count as from above
# Attempts go on up to this many times IK_ATTEMPTS while nothing is found: free solutions of
# tight poses (a cup held low in front of the body) are rare among random starts, and the
# screen, which searches differently, may have found one.
IK_PERSISTENCE = 3
IK_CANDIDATES = 6  # collision-free solutions to choose from
IK_RANDOM_RESTARTS = 3  # random starts per attempt after the seeded ones (side grasps need many)


@dataclass
class SkillContext:
    world: World
    rng: np.random.Generator
    planning_s: float = 0.0
    notes: list[str] = field(default_factory=list)


def joints(ctx: SkillContext, robot: str) -> FloatArray:
    return arm_joints(ctx.world.client, ctx.world.physics.robots[robot])


def ee(ctx: SkillContext, robot: str) -> FloatArray:
    return ee_matrix(ctx.world.client, ctx.world.physics.robots[robot])


def carried_by(ctx: SkillContext, robots: Sequence[str]) -> list[Carried]:
    out = []
    for r in robots:
        grasp = ctx.world.grasps.get(r)
        if grasp is not None:
            out.append(Carried(r, grasp.object, grasp.ee_from_object))
    return out


def collision_fn(
    ctx: SkillContext,
    robots: Sequence[str],
    allowed: frozenset[tuple[str, str]] = frozenset(),
    clearance: float = 0.0,
    hand_clearance: float = 0.0,
) -> CollisionFn:
    sync_mirror(ctx.world)
    openings = gripper_openings(ctx.world)
    fingers = {r: openings[r] if r in ctx.world.grasps else 0.08 for r in robots}
    carried = carried_by(ctx, robots)
    # Containers with contents are kept upright (see gfc.sim.collision).
    upright = {
        c.object: upright_limit(object_matrix(ctx.world.physics, c.object))
        for c in carried
        if ctx.world.contents.get(c.object, 0) > 0
    }
    return make_collision_fn(ctx.world, robots, carried, fingers, allowed, upright, clearance, hand_clearance)


def clear_of_other_arms(ctx: SkillContext, robot: str) -> CollisionFn:
    """A test of ``robot``'s joints (open hand) against its own links and the other arms only:
    objects and the table may be touched. For a hand-over's approach, which ends touching the
    object the other hand holds and must not sweep the arm through the giver's."""
    sync_mirror(ctx.world)
    touchable = [*ctx.world.physics.objects, "table"]
    return make_collision_fn(
        ctx.world, [robot], (), {robot: 2 * FINGER_MAX}, frozenset((robot, n) for n in touchable)
    )


def upright_limit(world_from_object: FloatArray) -> float:
    """How far (rad) a carried container may tilt: ``UPRIGHT_TILT``, or a little more than it
    leans now (a grasp can leave it leaning, and the motion must be able to start)."""
    now = math.acos(max(-1.0, min(1.0, float(world_from_object[2, 2]))))
    return max(UPRIGHT_TILT, now + LEAN_MARGIN)


def limit_margin(q: FloatArray) -> float:
    """Smallest distance to a joint limit, as a fraction of that joint's range."""
    span = UPPER_LIMITS - LOWER_LIMITS
    return float(np.min(np.minimum(q - LOWER_LIMITS, UPPER_LIMITS - q) / span))


def aimed_home(world_from_base: FloatArray, world_from_ee: FloatArray) -> FloatArray:
    """The home configuration turned (joint 1) to face the target: a natural IK start that
    keeps the elbow up and the wrist away from its limits."""
    base_from_ee = np.linalg.inv(world_from_base) @ world_from_ee
    q = np.asarray(HOME_JOINTS, dtype=np.float64).copy()
    q[0] = float(np.arctan2(base_from_ee[1, 3], base_from_ee[0, 3]))
    return q


def free_ik(
    ctx: SkillContext,
    robot: str,
    world_from_ee: FloatArray,
    check: CollisionFn,
    what: str,
    follow: Sequence[FloatArray] = (),
    line_guard: CollisionFn | None = None,
) -> FloatArray:
    """A collision-free IK solution, or type 1 (none exists) / type 2 (all of them collide).

    Several solutions are gathered (from the current joints, from home, from random starts) and
    the one farthest from the joint limits wins: a straight lift or a pour that follows must not
    start at a limit.
    """
    return free_ik_solutions(ctx, robot, world_from_ee, check, what, follow, line_guard)[0]


def free_ik_solutions(
    ctx: SkillContext,
    robot: str,
    world_from_ee: FloatArray,
    check: CollisionFn,
    what: str,
    follow: Sequence[FloatArray] = (),
    line_guard: CollisionFn | None = None,
) -> list[FloatArray]:
    """Up to ``IK_CANDIDATES`` collision-free IK solutions, farthest from the joint limits first;
    raises as ``free_ik`` when there is none. ``line_guard``: the collision test the straight
    lines to ``follow`` must pass instead of the arm's own links alone (it must test those too,
    as ``clear_of_other_arms`` does)."""
    current = joints(ctx, robot)
    seeds = [
        current,
        aimed_home(ctx.world.physics.robots[robot].world_from_base, world_from_ee),
        np.asarray(HOME_JOINTS),
    ]
    found: list[FloatArray] = []
    collisions: list[str] = []
    dead_ends = 0
    # The straight lines that follow may touch the scene, never fold the arm into itself (a
    # long pull's end did, links 0 and 4, on a branch another start tracks cleanly).
    self_check = self_collision_fn(ctx.world, robot) if line_guard is None else line_guard

    def consider(q: FloatArray | None) -> None:
        nonlocal dead_ends
        if q is None:
            return
        hit = check(q)
        if (
            hit is None
            and follow
            and not tracks_lines(ctx.world, robot, q, [world_from_ee, *follow], ctx.rng, self_check)
        ):
            dead_ends += 1
        elif hit is None:
            found.append(q)
        else:
            collisions.append(f"{hit.moving} with {hit.other}")

    for attempt in range(IK_ATTEMPTS * IK_PERSISTENCE):
        if (attempt >= IK_ATTEMPTS and found) or len(found) >= IK_CANDIDATES:
            break
        seed = seeds[attempt] if attempt < len(seeds) else current
        consider(
            solve_ik(
                ctx.world,
                robot,
                world_from_ee,
                seed,
                ctx.rng,
                restarts=0 if attempt < len(seeds) else IK_RANDOM_RESTARTS,
            )
        )
    if not found:
        # Rescue from random starts. The attempts above after the seeded ones start from the
        # current joints, where solve_ik's first try lands on the same solution whenever it
        # converges, so a pose whose first solutions collide or dead-end failed although other
        # solutions exist (the screen, which starts at random, finds them: 10 of the 20 top-1
        # failures of GFC's first 64 Hammer Place trials in bimanual_s11_ik_repeat.jsonl).
        # Only poses that would fail otherwise get here, so every execution that succeeded
        # before, the tasks' reference actions included, keeps its solutions and random stream
        # (drawing random solutions always knocked placed blocks over in reference scenes).
        # Each call starts from IK_RANDOM_RESTARTS + 1 random configurations: from one, IK
        # converges about one time in seven for a pour's tipping pose, and a pour the screen
        # passed (18 of 24 free solutions could tip) failed when 2 of 24 single starts
        # converged, both on branches that could not (Pour Cup seed 4, session 17). Lines to
        # follow get three times the calls: in Pour Cup seed 3 one in 29 free solutions could
        # follow the tip (the others met joint 5's limit on the way).
        for _ in range(IK_ATTEMPTS * (IK_PERSISTENCE if follow else 1)):
            start = ctx.rng.uniform(LOWER_LIMITS, UPPER_LIMITS)
            consider(solve_ik(ctx.world, robot, world_from_ee, start, ctx.rng, restarts=IK_RANDOM_RESTARTS))
            if len(found) >= IK_CANDIDATES:
                break
    if found:
        return sorted(found, key=limit_margin, reverse=True)
    if dead_ends:
        raise SkillFailure(
            FailureType.METHOD,
            f"{robot}: from no IK solution for {what} can the straight approach that follows be made",
        )
    if collisions:
        raise SkillFailure(
            FailureType.PATH, f"{robot}: every IK solution for {what} collides ({collisions[0]})"
        )
    p = world_from_ee[:3, 3]
    raise SkillFailure(
        FailureType.METHOD,
        f"{robot}: no IK solution for {what} at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f})",
    )


def reach(
    ctx: SkillContext,
    robot: str,
    world_from_ee: FloatArray,
    what: str,
    follow: Sequence[FloatArray] = (),
    line_guard: CollisionFn | None = None,
) -> None:
    """Plan a collision-free joint path to the pose (with what the robot holds) and execute it.

    ``follow``: end-effector poses the robot will then reach in straight lines; the goal
    configuration is chosen so that it can (``line_guard``: as ``free_ik_solutions``).
    """
    plain = collision_fn(ctx, [robot])
    goal = free_ik(ctx, robot, world_from_ee, plain, what, follow, line_guard)
    start = joints(ctx, robot)
    # On the way, the hand keeps HAND_CLEARANCE from objects and what it carries keeps
    # CARRIED_CLEARANCE from everything, where both ends of the motion allow it (a pour's meeting
    # or a hand-over ends closer: planned as before), and where a path with those margins exists.
    carried = CARRIED_CLEARANCE if carried_by(ctx, [robot]) else 0.0
    wide = collision_fn(ctx, [robot], clearance=carried, hand_clearance=HAND_CLEARANCE)
    check = wide if wide(start) is None and wide(goal) is None else plain
    result = plan_motion(check, start, goal, ctx.rng)
    ctx.planning_s += result.planning_s
    if result.path is None and check is wide:
        result = plan_motion(plain, start, goal, ctx.rng)
        ctx.planning_s += result.planning_s
    if result.path is None:
        raise SkillFailure(FailureType.PATH, f"{robot}: no collision-free path to {what}: {result.reason}")
    execute_paths(ctx.world, {robot: result.path}, {robot: gripper_target(ctx.world, robot)})


def straight(
    ctx: SkillContext,
    robot: str,
    world_from_ee: FloatArray,
    what: str,
    speed: float = 0.5,
    finger: float | None = None,
    guard: CollisionFn | None = None,
) -> list[FloatArray]:
    """Move the end effector in a straight line (approach, retreat, lift); contact is allowed.
    ``finger``: the finger command on the way (default: keep the grip, or open); ``guard``: a
    collision test every joint waypoint must pass (type 2 otherwise, nothing moved). Returns the
    joint waypoints driven (the first: the joints it started from)."""
    start = ee(ctx, robot)
    poses = interpolate_poses(start, world_from_ee, waypoint_count(start, world_from_ee))
    path = cartesian_joint_path(ctx.world, robot, joints(ctx, robot), poses, ctx.rng)
    if path is None:
        raise SkillFailure(FailureType.METHOD, f"{robot}: cannot move in a straight line to {what}")
    if guard is not None:
        hit = next((h for h in map(guard, path) if h is not None), None)
        if hit is not None:
            raise SkillFailure(
                FailureType.PATH,
                f"{robot}: the straight line to {what} collides ({hit.moving} with {hit.other})",
            )
    fingers = gripper_target(ctx.world, robot) if finger is None else finger
    execute_paths(ctx.world, {robot: path}, {robot: fingers}, speed=speed)
    return path


def translated(world_from_frame: FloatArray, offset: Sequence[float] | FloatArray) -> FloatArray:
    out = world_from_frame.copy()
    out[:3, 3] += np.asarray(offset)
    return out


def backed_off(world_from_ee: FloatArray, distance: float) -> FloatArray:
    """The pose ``distance`` back along the gripper's approach (z) axis."""
    return translated(world_from_ee, -distance * world_from_ee[:3, 2])


def check_grasp_on_object(world: World, obj: str, world_from_grasp: FloatArray) -> None:
    """Type 1 when the grasp point is not on the object (outside its box by more than 1 cm)."""
    kind = object_kind(world.physics.objects[obj].kind)
    object_from_grasp = invert(object_matrix(world.physics, obj)) @ world_from_grasp
    p = object_from_grasp[:3, 3]
    half = np.asarray(kind.half_extents)
    centre = np.array([0.0, 0.0, half[2]])
    outside = np.maximum(np.abs(p - centre) - half, 0.0)
    if float(np.linalg.norm(outside)) > 0.01:
        raise SkillFailure(
            FailureType.METHOD,
            f"grasp point is {np.linalg.norm(outside) * 100:.1f} cm outside the {obj}",
        )


def require_holding(world: World, robot: str, obj: str | None) -> None:
    grasp = world.grasps.get(robot)
    if obj is not None and (grasp is None or grasp.object != obj):
        held = "nothing" if grasp is None else grasp.object
        raise SkillFailure(FailureType.METHOD, f"{robot} must hold {obj} but holds {held}")


def require_free(world: World, robot: str) -> None:
    if robot in world.grasps:
        raise SkillFailure(FailureType.METHOD, f"{robot} already holds {world.grasps[robot].object}")


def held_offset_error(ctx: SkillContext, robot: str) -> float:
    """How far (m) the held object has moved relative to the hand since it was grasped."""
    grasp = ctx.world.grasps[robot]
    now = invert(ee(ctx, robot)) @ object_matrix(ctx.world.physics, grasp.object)
    return float(np.linalg.norm(now[:3, 3] - grasp.ee_from_object[:3, 3]))


def symmetries(world: World, obj: str) -> list[FloatArray]:
    """Rigid motions (object frame, 4x4) that map ``obj`` onto itself, the identity first: for
    a cube (a block) the 24 rotations about its centre, for a square footprint the quarter
    turns about its vertical axis, else none but the identity. A pose of the object composed
    with one of them is the same physical pose: a block that a pull tipped onto its side is
    still a block standing upright."""
    kind = object_kind(world.physics.objects[obj].kind)
    if not kind.quarter_turn_symmetric:
        return [np.eye(4)]
    hx, _, hz = kind.half_extents
    cube = math.isclose(hx, hz)
    centre = np.array([0.0, 0.0, hz])
    out = [np.eye(4)]
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            rotation = np.zeros((3, 3))
            for row, (col, sign) in enumerate(zip(perm, signs, strict=True)):
                rotation[row, col] = sign
            if np.linalg.det(rotation) < 0 or np.allclose(rotation, np.eye(3)):
                continue
            if not cube and not np.isclose(rotation[2, 2], 1.0):
                continue
            motion = np.eye(4)
            motion[:3, :3], motion[:3, 3] = rotation, centre - rotation @ centre
            out.append(motion)
    return out


def upright_first(poses: Sequence[FloatArray], limit: int = 4) -> list[FloatArray]:
    """The first pose (the commanded one), then up to ``limit - 1`` of the others whose hand
    points down most steeply (within 30 degrees of straight down), steepest first."""
    rest = sorted(poses[1:], key=lambda pose: float(pose[2, 2]))
    return [poses[0], *[pose for pose in rest if pose[2, 2] < -DOWN_COS][: limit - 1]]


def first_reachable(poses: Iterable[FloatArray], attempt: Callable[[FloatArray], None]) -> FloatArray:
    """The first of equivalent hand poses ``attempt`` (a ``reach`` to it) succeeds for; the
    failure for the first pose if none. A ``reach`` that fails has not moved the arm. The
    executor tries the equivalents only once the commanded pose has failed, so every execution
    that worked before is unchanged. A pull tips the block onto its side now and then; the
    plan's grasp (from above, in the block's frame) is then a side grasp no arm can make, and an
    equivalent one comes from above again (Hook Reach T1, session 13: 16 of 96 top-1 trials
    failed at that pick with "no IK solution for the pre-grasp")."""
    first: SkillFailure | None = None
    for pose in poses:
        try:
            attempt(pose)
        except SkillFailure as exc:
            if exc.failure_type == FailureType.PHYSICS:
                raise
            first = first or exc
            continue
        return pose
    assert first is not None
    raise first


def hands_clear_first(
    ctx: SkillContext,
    robot: str,
    obj: str,
    hands: Sequence[FloatArray],
    finger: float,
    around_object: bool = False,
) -> Iterator[FloatArray]:
    """Equivalent hand poses (the commanded one first; ``symmetries``) reordered so that those
    where the arm, its fingers at ``finger`` (m a finger), touches nothing but ``obj`` come first,
    each group in the given order; where none is clear the order is kept. A commanded pose that
    is clear stays first, so that execution is unchanged; one whose hand would meet something
    gives way to a turned equivalent (a block is the same block turned by 90 degrees): at a
    placement, fingers opening into the box wall or a neighbour (ADR 0010); at a grasp, the open
    hand coming down on the rack's bar. It sees the world as it is, neighbours a few millimetres
    off their plan included. Its IK draws on its own random stream, so checking leaves the
    execution's random draws as they were.

    ``around_object`` (a grasp): the open fingers must also be around ``obj``, not in it. A
    cube grasped 1 cm off its centre along the fingers has a finger come down on its top; the
    same grasp turned a quarter turn has the offset across the fingers, and they close on the
    cube's faces (ADR 0011)."""
    if len(hands) < 2:
        yield from hands
        return
    sync_mirror(ctx.world)
    check = make_collision_fn(
        ctx.world, [robot], fingers={robot: 2 * finger}, allowed=frozenset({(robot, obj)})
    )
    own = dataclasses.replace(ctx, rng=np.random.default_rng(0), notes=[])

    def clear(world_from_ee: FloatArray) -> bool:
        try:
            q = free_ik(own, robot, world_from_ee, check, "the check of the hand")
        except SkillFailure:
            return False
        if not around_object:
            return True
        set_joints(ctx.world.mirror.client, ctx.world.mirror.robots[robot], q, finger)
        return finger_depth(ctx.world, robot, obj) <= FINGER_LANDING

    # Lazily, in the given order: a clear pose is handed on as soon as it is found, so that when
    # the commanded pose is clear and reachable (nearly always) no other pose is checked. A
    # reach that fails moves nothing and the checks draw on their own random stream, so the
    # order, and every execution, is that of checking them all first (which took a quarter of
    # a Rearrangement Push execution's time, session 24's profile).
    blocked: list[FloatArray] = []
    for hand in hands:
        if clear(hand):
            yield hand
        else:
            blocked.append(hand)
    yield from blocked
