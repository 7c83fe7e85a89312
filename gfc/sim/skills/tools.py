"""``push`` and ``pull`` with a held tool (the hook), parameterised as in STAP/GSC.

Action ``(x, y, r, theta)``: the tool's ``tip`` frame is brought to ``(x, y)`` in the target's
*approach frame* (metres, at the tool's resting height above the table), with the tool's x axis
at angle ``theta`` (radians) from that frame's x axis; then the end effector travels ``r`` metres
in a straight line along the tool's x axis: forwards (+x, away from the tip's hook) for push,
backwards (-x, dragging the target with the hook) for pull. ``r`` must be in (0, 0.3].

The approach frame (``gfc.geometry.approach_frame``) sits at the target's centre with its x axis
pointing horizontally from the acting robot's base to the target. STAP and GSC express these
parameters in the target's own frame; we do not, because a block's yaw is arbitrary (a square
block looks the same every quarter turn) while what makes a stroke reachable and useful (the
tool pointing away from the robot, the block inside the hook) is fixed relative to the
base-to-target line. In the target's frame the same good stroke is a different action for every
target yaw, and a model trained on a few hundred rows did not learn that rotation (41 % and 55 %
hit rates alone, type 1, docs/skill_learning.md); in the approach frame it is one action.
"""

from __future__ import annotations

import math

import numpy as np

from gfc.geometry import FloatArray, approach_frame, invert, pose7_to_matrix
from gfc.kinds import object_kind
from gfc.plan.schema import Step
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.skills.motions import SkillContext, ee, reach, require_holding, straight, translated
from gfc.sim.world import object_matrix

HOVER = 0.08  # m above the working height where the tool is lowered from
MAX_STROKE = 0.3
RETREAT_FALLBACK = 0.03  # m: the lift tried when the full one cannot be tracked
MIN_TARGET_MOTION = 0.01  # m the target must move for the stroke to count


def _stroke(ctx: SkillContext, step: Step, action: FloatArray, sign: float) -> str:
    world, robot, tool, target = ctx.world, step.robot, step.object, step.target
    assert tool is not None
    assert target is not None
    require_holding(world, robot, tool)
    x, y, r, theta = (float(v) for v in action)
    if not 0.0 < r <= MAX_STROKE:
        raise SkillFailure(FailureType.METHOD, f"stroke length r = {r:.2f} m outside (0, {MAX_STROKE}]")
    tool_kind = object_kind(world.physics.objects[tool].kind)
    if "tip" not in tool_kind.frames:
        raise SkillFailure(FailureType.METHOD, f"{tool} has no tip to push or pull with")
    world_from_target = object_matrix(world.physics, target)
    world_from_base = world.physics.robots[robot].world_from_base
    world_from_approach = approach_frame(world_from_base[:3, 3], world_from_target[:3, 3])
    yaw = math.atan2(world_from_approach[1, 0], world_from_approach[0, 0]) + theta
    tip_world = world_from_approach @ np.array([x, y, 0.0, 1.0])
    object_from_tip = pose7_to_matrix(tool_kind.frame("tip"))
    # The tool lies flat: its bottom face at table height while it works.
    world_from_tool = np.eye(4)
    c, s = math.cos(yaw), math.sin(yaw)
    world_from_tool[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    world_from_tool[:3, 3] = tip_world[:3] - world_from_tool[:3, :3] @ object_from_tip[:3, 3]
    world_from_tool[2, 3] = world_from_target[2, 3] + 0.002
    world_from_ee = world_from_tool @ invert(world.grasps[robot].ee_from_object)
    direction = sign * world_from_tool[:3, 0]
    stroke_end = translated(world_from_ee, r * direction)
    above = translated(world_from_ee, [0.0, 0.0, HOVER])
    reach(ctx, robot, above, f"above the {target}", [world_from_ee, stroke_end])
    straight(ctx, robot, world_from_ee, "the working height")
    before = object_matrix(world.physics, target)[:3, 3]
    straight(ctx, robot, stroke_end, "the end of the stroke", speed=0.4)
    _retreat(ctx, robot)
    moved = float(np.linalg.norm(object_matrix(world.physics, target)[:2, 3] - before[:2]))
    if moved < MIN_TARGET_MOTION:
        raise SkillFailure(
            FailureType.PHYSICS, f"the {tool} did not move the {target} ({moved * 100:.1f} cm)"
        )
    return f"{'pushed' if sign > 0 else 'pulled'} {target} {moved * 100:.1f} cm"


def _retreat(ctx: SkillContext, robot: str) -> None:
    """Lift the tool off the table, straight up; a pull can end with the hand close to the base,
    where a full lift cannot always be tracked: then a shorter one, and else the arm stays (the
    stroke itself is done; the next step starts from here)."""
    for height in (HOVER, RETREAT_FALLBACK):
        try:
            straight(ctx, robot, translated(ee(ctx, robot), [0.0, 0.0, height]), "the retreat")
            return
        except SkillFailure:
            continue
    ctx.notes.append(f"{robot} could not lift the tool after the stroke")


def push(ctx: SkillContext, step: Step, action: FloatArray) -> str:
    return _stroke(ctx, step, action, 1.0)


def pull(ctx: SkillContext, step: Step, action: FloatArray) -> str:
    return _stroke(ctx, step, action, -1.0)
