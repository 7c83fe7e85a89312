"""``move``: bring the held object (or the empty hand) to a pose in the robot's base frame.

The action is the pose of what the move is about: the held object when there is one, so that a
plan's constraints on the object are what the robot executes; the hand's target follows from
the grasp the robot really has (as for ``place``)."""

from __future__ import annotations

from gfc.geometry import FloatArray, invert, pose9_to_matrix
from gfc.plan.schema import Step
from gfc.sim.ik import pose_error
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.skills.motions import SkillContext, ee, held_offset_error, reach, require_holding
from gfc.sim.world import World

REACHED = 0.01  # m


def hand_target(world: World, robot: str, obj: str | None, action: FloatArray) -> FloatArray:
    """World pose of the end effector that puts ``obj`` (held by ``robot``; the hand itself when
    None) at ``action``, a pose9 in the robot's base frame."""
    grasp = None if obj is None else world.grasps[robot].ee_from_object
    return hand_for(world.physics.robots[robot].world_from_base, action, grasp)


def hand_for(
    world_from_base: FloatArray, action: FloatArray, ee_from_object: FloatArray | None
) -> FloatArray:
    """``hand_target`` from the robot's base and the grasp (``None``: an empty hand)."""
    world_from_target = world_from_base @ pose9_to_matrix(action)
    if ee_from_object is None:
        return world_from_target
    return world_from_target @ invert(ee_from_object)


def move(ctx: SkillContext, step: Step, action: FloatArray) -> str:
    world, robot = ctx.world, step.robot
    require_holding(world, robot, step.object)
    world_from_ee = hand_target(world, robot, step.object, action)
    reach(ctx, robot, world_from_ee, "the move target")
    position_error, _ = pose_error(ee(ctx, robot), world_from_ee)
    if position_error > REACHED:
        raise SkillFailure(
            FailureType.PHYSICS, f"{robot} stopped {position_error * 100:.1f} cm short (blocked)"
        )
    if step.object is not None and held_offset_error(ctx, robot) > 0.02:
        raise SkillFailure(FailureType.PHYSICS, f"{step.object} slipped in {robot}'s hand")
    return f"{robot} moved" + (f" with {step.object}" if step.object else "")
