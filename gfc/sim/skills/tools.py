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
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gfc.geometry import FloatArray, approach_frame, invert, pose7_to_matrix
from gfc.kinds import (
    HOOK_SHAFT_Y,
    HOOK_TIP_BAR_HALF_X,
    MAX_STROKE,
    MAX_STROKE_TURN,
    PIVOT_TRAVEL,
    STROKE_CLEARANCE,
    STROKE_SIGNS,
    ObjectKind,
    folded_turn,
    hook_face_span,
    object_kind,
    pivot_shift,
)
from gfc.plan.schema import Step
from gfc.sim.collision import self_collision_fn
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.skills.motions import (
    SkillContext,
    ee,
    reach,
    require_holding,
    straight,
    translated,
)
from gfc.sim.world import object_matrix

HOVER = 0.08  # m above the working height where the tool is lowered from
RETREAT_FALLBACK = 0.03  # m: the lift tried when the full one cannot be tracked
MIN_TARGET_MOTION = 0.01  # m the target must move for the stroke to count
CONTACT_SLACK = 0.003  # m: what a contact prediction may be off by


@dataclass(frozen=True)
class StrokePoses:
    """Where a stroke puts the tool and the hand (world 4x4s), as the executor commands them."""

    world_from_tool: FloatArray  # the tool flat on the table at the stroke's start
    above: FloatArray  # the hand HOVER above the start, where the tool is lowered from
    start: FloatArray  # the hand at the working height
    end: FloatArray  # the hand after travelling r along the stroke
    direction: FloatArray  # (3,) unit travel direction (world, horizontal)


def _yaw_rotation(yaw: float) -> FloatArray:
    """The 3x3 rotation about the world's z axis by ``yaw`` (rad)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def stroke_poses(
    world_from_base: FloatArray,
    world_from_target: FloatArray,
    tool_kind: ObjectKind,
    ee_from_object: FloatArray,
    action: FloatArray,
    sign: float,
) -> StrokePoses:
    """The hand poses of a push (``sign`` +1) or pull (-1) with ``action`` ``(x, y, r, theta)``;
    raises type 1 for a stroke length outside (0, MAX_STROKE] or a tool without a tip. Shared by
    the executor and the kinematic screen (gfc/sim/screen.py), so both ask for the same poses."""
    x, y, r, theta = (float(v) for v in action)
    if not 0.0 < r <= MAX_STROKE:
        raise SkillFailure(FailureType.METHOD, f"stroke length r = {r:.2f} m outside (0, {MAX_STROKE}]")
    if "tip" not in tool_kind.frames:
        raise SkillFailure(FailureType.METHOD, f"the {tool_kind.name} has no tip to push or pull with")
    world_from_approach = approach_frame(world_from_base[:3, 3], world_from_target[:3, 3])
    yaw = math.atan2(world_from_approach[1, 0], world_from_approach[0, 0]) + theta
    tip_world = world_from_approach @ np.array([x, y, 0.0, 1.0])
    object_from_tip = pose7_to_matrix(tool_kind.frame("tip"))
    # The tool lies flat: its bottom face at table height while it works.
    world_from_tool = np.eye(4)
    world_from_tool[:3, :3] = _yaw_rotation(yaw)
    world_from_tool[:3, 3] = tip_world[:3] - world_from_tool[:3, :3] @ object_from_tip[:3, 3]
    world_from_tool[2, 3] = world_from_target[2, 3] + 0.002
    start = world_from_tool @ invert(ee_from_object)
    direction = sign * world_from_tool[:3, 0]
    return StrokePoses(
        world_from_tool,
        translated(start, [0.0, 0.0, HOVER]),
        start,
        translated(start, r * direction),
        direction,
    )


@dataclass(frozen=True)
class StrokeContact:
    """What a stroke does to its target, predicted from geometry alone (no physics)."""

    gap: float  # m the hand travels before the tool touches the target
    travel: float  # m the target is carried (the stroke's r less the gap)
    turn: float = 0.0  # rad the target's face is turned from the tool's (folded to +-45 deg)
    pivot: tuple[float, float] = (0.0, 0.0)  # m along and across the stroke: ``pivot_shift``

    def moved(self, world_from_target: FloatArray, direction: FloatArray) -> FloatArray:
        """The target's pose after the stroke: carried ``travel`` along ``direction``, turned by
        ``-turn`` flat against the tool's face about the corner the face met (``pivot``)."""
        fade = min(1.0, self.travel / PIVOT_TRAVEL)
        across = np.array([-direction[1], direction[0], 0.0])
        shift = (self.travel + fade * self.pivot[0]) * direction + fade * self.pivot[1] * across
        out = translated(world_from_target, shift)
        out[:3, :3] = _yaw_rotation(-self.turn) @ out[:3, :3]
        return out


def stroke_contact(
    tool_kind: ObjectKind,
    world_from_tool: FloatArray,
    target_half_extents: Sequence[float],
    world_from_target: FloatArray,
    r: float,
    sign: float,
) -> StrokeContact:
    """Where the hook meets a box-shaped target on a stroke (``sign`` +1 push, -1 pull) of
    length ``r`` from the tool pose ``world_from_tool``; raises type 3 when it would not move
    it (outside the hook's face, met more than ``MAX_STROKE_TURN`` askew, or farther than r) or
    type 2 when the lowered tool would land on it. Used by the kinematic screen to follow a
    stroke without physics: the target slides along the stroke by what is left of r once the gap
    is closed, its face turned flat against the tool's (a few mm and degrees off what the
    simulator does for the tasks' strokes)."""
    tool_from_target = invert(world_from_tool) @ world_from_target
    bx, by = tool_from_target[0, 3], tool_from_target[1, 3]
    c, s = abs(tool_from_target[0, 0]), abs(tool_from_target[1, 0])
    ex, ey = float(target_half_extents[0]), float(target_half_extents[1])
    half_x, half_y = c * ex + s * ey, s * ex + c * ey  # the target's extent along the tool's axes
    tip_x = float(tool_kind.frame("tip")[0])
    lateral = hook_face_span(sign)
    if sign > 0:
        gap = (bx - half_x) - (tip_x + HOOK_TIP_BAR_HALF_X)
    else:
        gap = (tip_x - HOOK_TIP_BAR_HALF_X) - (bx + half_x)
        if by - half_y < HOOK_SHAFT_Y[1] and bx - half_x < tip_x + HOOK_TIP_BAR_HALF_X:
            raise SkillFailure(
                FailureType.PATH, f"the shaft would land on the target ({by * 100:.1f} cm to its side)"
            )
    if not lateral[0] <= by <= lateral[1]:
        raise SkillFailure(
            FailureType.PHYSICS, f"the target's centre is {by * 100:.1f} cm to the side: off the hook's face"
        )
    yaw = math.atan2(tool_from_target[1, 0], tool_from_target[0, 0])
    turn = folded_turn(yaw)
    if abs(turn) > MAX_STROKE_TURN:
        raise SkillFailure(
            FailureType.PHYSICS,
            f"the target meets the hook's face {math.degrees(abs(turn)):.0f} deg askew (at most "
            f"{math.degrees(MAX_STROKE_TURN):.0f}): the hook would catch its corner",
        )
    if gap < -CONTACT_SLACK:
        raise SkillFailure(
            FailureType.PATH, f"the lowered tool would land on the target ({-gap * 100:.1f} cm)"
        )
    if gap < STROKE_CLEARANCE / 2:
        # A tool lowered within a few millimetres of the target's face catches its edge.
        raise SkillFailure(
            FailureType.PATH,
            f"the tool would come down {gap * 100:.1f} cm from the target (at least "
            f"{STROKE_CLEARANCE * 50:.1f} cm)",
        )
    travel = r - max(gap, 0.0)
    if travel < MIN_TARGET_MOTION + CONTACT_SLACK:
        raise SkillFailure(
            FailureType.PHYSICS,
            f"the stroke ends {gap * 100:.1f} cm away, {travel * 100:.1f} cm into the target",
        )
    return StrokeContact(gap, travel, turn, pivot_shift(yaw, ex, ey))


def _stroke(ctx: SkillContext, step: Step, action: FloatArray, sign: float) -> str:
    world, robot, tool, target = ctx.world, step.robot, step.object, step.target
    assert tool is not None
    assert target is not None
    require_holding(world, robot, tool)
    poses = stroke_poses(
        world.physics.robots[robot].world_from_base,
        object_matrix(world.physics, target),
        object_kind(world.physics.objects[tool].kind),
        world.grasps[robot].ee_from_object,
        action,
        sign,
    )
    reach(ctx, robot, poses.above, f"above the {target}", [poses.start, poses.end])
    straight(ctx, robot, poses.start, "the working height")
    before = object_matrix(world.physics, target)[:3, 3]
    straight(
        ctx, robot, poses.end, "the end of the stroke", speed=0.4, guard=self_collision_fn(ctx.world, robot)
    )
    _retreat(ctx, robot)
    moved = float(np.linalg.norm(object_matrix(world.physics, target)[:2, 3] - before[:2]))
    if moved < MIN_TARGET_MOTION:
        raise SkillFailure(
            FailureType.PHYSICS, f"the {tool} did not move the {target} ({moved * 100:.1f} cm)"
        )
    return f"{'pushed' if sign > 0 else 'pulled'} {target} {moved * 100:.1f} cm"


def _retreat(ctx: SkillContext, robot: str) -> None:
    """Lift the tool off the table, straight up; a pull can end with the hand close to the base,
    where a full lift cannot always be tracked, or is tracked only by folding the elbow into the
    arm's base (the next step's motion then starts in collision: 3 of GFC's first 7 top-1
    failures of Hook Reach T1, session 22): then a shorter one, and else the arm stays (the
    stroke itself is done; the next step starts from here)."""
    guard = self_collision_fn(ctx.world, robot)
    for height in (HOVER, RETREAT_FALLBACK):
        try:
            straight(ctx, robot, translated(ee(ctx, robot), [0.0, 0.0, height]), "the retreat", guard=guard)
            return
        except SkillFailure:
            continue
    ctx.notes.append(f"{robot} could not lift the tool after the stroke")


def push(ctx: SkillContext, step: Step, action: FloatArray) -> str:
    return _stroke(ctx, step, action, STROKE_SIGNS["push"])


def pull(ctx: SkillContext, step: Step, action: FloatArray) -> str:
    return _stroke(ctx, step, action, STROKE_SIGNS["pull"])
