"""``move``: bring the end effector (and what it holds) to a pose in the robot's base frame."""

from __future__ import annotations

from gfc.geometry import FloatArray, pose9_to_matrix
from gfc.plan.schema import Step
from gfc.sim.ik import pose_error
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.skills.motions import SkillContext, ee, held_offset_error, reach, require_holding

REACHED = 0.01  # m


def move(ctx: SkillContext, step: Step, action: FloatArray) -> str:
    world, robot = ctx.world, step.robot
    require_holding(world, robot, step.object)
    world_from_ee = world.physics.robots[robot].world_from_base @ pose9_to_matrix(action)
    reach(ctx, robot, world_from_ee, "the move target")
    position_error, _ = pose_error(ee(ctx, robot), world_from_ee)
    if position_error > REACHED:
        raise SkillFailure(
            FailureType.PHYSICS, f"{robot} stopped {position_error * 100:.1f} cm short (blocked)"
        )
    if step.object is not None and held_offset_error(ctx, robot) > 0.02:
        raise SkillFailure(FailureType.PHYSICS, f"{step.object} slipped in {robot}'s hand")
    return f"{robot} moved" + (f" with {step.object}" if step.object else "")
