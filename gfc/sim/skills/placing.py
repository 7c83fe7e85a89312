"""``place``: put the held object at a pose in the target's frame and let go."""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb

from gfc.geometry import FloatArray, invert, pose9_to_matrix
from gfc.plan.schema import Step
from gfc.sim.control import execute_paths, open_gripper
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.panda import FINGER_JOINTS, FINGER_MAX, command_fingers, finger_positions
from gfc.sim.skills.motions import (
    SkillContext,
    ee,
    first_reachable,
    hands_clear_first,
    joints,
    reach,
    require_holding,
    straight,
    symmetries,
    translated,
    upright_first,
)
from gfc.sim.world import object_matrix
from gfc.sim.world import step as physics_step

PLACE_APPROACH = 0.08  # m above the placement, where the straight descent starts
SETTLE_STEPS = 120
POSITION_TOLERANCE = 0.03  # m between commanded and resting pose after release
TILT_TOLERANCE = math.radians(20.0)
# m each finger opens beyond where it holds the object to let go, and stays at on the retreat.
# Opening fully (4 cm a finger) pressed a finger into the box wall or the neighbour block 6 mm
# away, where it stuck at the motor's full force and the retreat dragged the block 5-9 mm
# (Constrained Packing T3, session 14: 3 of 5 releases in seed 1).
RELEASE_TRAVEL = 0.006
JAM_FORCE = 1.0  # N: a finger pressing on the released object this hard is jammed on it
JAMMED_RELEASE_FORCE = 140.0  # N: the Franka hand's peak grasping force (70 N continuous)
JAM_STEPS = 60


def place(ctx: SkillContext, step: Step, action: FloatArray) -> str:
    world, robot, obj, target = ctx.world, step.robot, step.object, step.target
    assert obj is not None
    assert target is not None
    require_holding(world, robot, obj)
    commanded = object_matrix(world.physics, target) @ pose9_to_matrix(action)
    ee_from_object = world.grasps[robot].ee_from_object

    def descend_from_above(world_from_ee: FloatArray) -> None:
        above = translated(world_from_ee, [0.0, 0.0, PLACE_APPROACH])
        reach(ctx, robot, above, f"above the {target}", [world_from_ee])

    # The object at the commanded pose, or at one the same as it (a block turned over): hands.
    hands = upright_first([commanded @ same @ invert(ee_from_object) for same in symmetries(world, obj)])
    release = release_finger(ctx, robot)
    world_from_ee = first_reachable(hands_clear_first(ctx, robot, obj, hands, release), descend_from_above)
    world_from_goal = world_from_ee @ ee_from_object
    descent = straight(ctx, robot, world_from_ee, f"the placement of {obj}")
    open_gripper(world, robot, finger=release)
    _free_jammed_fingers(ctx, robot, obj, release)
    _retreat(ctx, robot, descent, release)
    open_gripper(world, robot)  # clear of everything now: the hand ends open, as it always did
    physics_step(world, SETTLE_STEPS)
    rest = object_matrix(world.physics, obj)
    error = float(np.linalg.norm(rest[:3, 3] - world_from_goal[:3, 3]))
    tilt = math.acos(max(-1.0, min(1.0, float(rest[:3, 2] @ world_from_goal[:3, 2]))))
    if error > POSITION_TOLERANCE or tilt > TILT_TOLERANCE:
        drop = world_from_goal[2, 3] - rest[2, 3]
        raise SkillFailure(
            FailureType.PHYSICS,
            f"{obj} did not stay where it was released: {error * 100:.1f} cm away "
            f"({drop * 100:.1f} cm lower), tilted {math.degrees(tilt):.0f} deg",
        )
    return f"placed {obj} on {target} ({error * 100:.1f} cm from the commanded pose)"


def _retreat(ctx: SkillContext, robot: str, descent: list[FloatArray], finger: float) -> None:
    """Straight up ``PLACE_APPROACH`` from where the hand let go; where that line cannot be
    tracked from there (a placement at the edge of the workspace, as the hook's on the rack: IK
    from the released hand finds no solution for the line's top), back along the descent's own
    joint path, which came down that line. Before this, 48 top-1 failures of the trial logs in
    docs/bench/trials (most tasks) were that retreat, after a good placement."""
    up = translated(ee(ctx, robot), [0.0, 0.0, PLACE_APPROACH])
    try:
        straight(ctx, robot, up, "the retreat", finger=finger)
    except SkillFailure:
        execute_paths(ctx.world, {robot: [joints(ctx, robot), *reversed(descent)]}, {robot: finger})


def _free_jammed_fingers(ctx: SkillContext, robot: str, obj: str, release: float) -> None:
    """Fingers still pressing on the object they were told to let go of, and on nothing else,
    are jammed on it: open them with the hand's peak force. A block set down a few millimetres
    above the box floor and held a few degrees turned in the grip stayed wedged between the pads
    (35 N each) at the drive's 40 N and at 70 N, and came up 8 cm with the retreat: "did not
    stay where it was released" (Constrained Packing T1 seed 35 of single_arm_s19.jsonl,
    replayed at session 23's code; 7 of GFC's 43 logged top-1 failures of Packing T1 and T3,
    logs single_arm_s19.jsonl and single_arm_s16.jsonl, ended 7-10 cm above the placement). At
    140 N they open and the block drops onto the floor. A finger that also touches a neighbour
    or a wall is left alone: at that force it would shove it."""
    world = ctx.world
    panda = world.physics.robots[robot]
    held = world.physics.objects[obj].body
    contacts = [
        contact
        for finger in FINGER_JOINTS
        for contact in pb.getContactPoints(bodyA=panda.body, linkIndexA=finger, physicsClientId=world.client)
    ]
    pressing = any(c[2] == held and c[9] > JAM_FORCE for c in contacts)
    if not pressing or any(c[2] != held for c in contacts):
        return
    command_fingers(world.client, panda, release, force=JAMMED_RELEASE_FORCE)
    physics_step(world, JAM_STEPS)
    ctx.notes.append(f"{robot}'s fingers were jammed on {obj}: opened at {JAMMED_RELEASE_FORCE:.0f} N")


def release_finger(ctx: SkillContext, robot: str) -> float:
    """The finger command (m a finger) that lets go of what the robot holds: ``RELEASE_TRAVEL``
    beyond the wider-open finger now."""
    fingers = finger_positions(ctx.world.client, ctx.world.physics.robots[robot])
    return min(FINGER_MAX, max(fingers) + RELEASE_TRAVEL)
