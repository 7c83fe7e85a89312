"""What the single-arm tasks (Hook Reach, Rearrangement Push, Constrained Packing; STAP/GSC style)
share: the acting arm, the grasps, the hook's rest on a rack and the slots in a box.

Every single-arm task is done by the right arm; the left arm stays at home (it is still in the
scene, as an obstacle, because the simulator always builds both Pandas).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from gfc.geometry import FloatArray, approach_frame
from gfc.kinds import object_kind
from gfc.tasks.base import RIGHT_BASE, grasp9, rot_z
from gfc.tasks.boxes import FLOOR

ROBOT = "right"

# The hook is held on its shaft (the shaft's centre line is at y = -0.045 in the hook frame), from
# above, 0.285 m behind the tip frame: far enough back that the hand stays clear of what the tip
# works on (the block; the rack's bar when pushing under it).
HOOK_GRASP = (-0.1, -0.045, 0.02)
BLOCK_GRASP_Z = 0.025  # from above, at the block's centre height
RACK_TOP = 2 * object_kind("rack").half_extents[2]  # the bar's top face, 0.12 m

# The hook lying on the rack's bar (rack frame): shaft along the bar (the hook turned -90 degrees
# in the rack frame), the shaft's 3 cm fully on the 10 cm bar (rack x from -0.05 to -0.02) and
# the hook's centre of mass (0.02 m off the shaft towards the hook end) over it at rack x = -0.01;
# the short hook part overhangs the bar's far edge by 2 cm, which it can since the mass is on the bar.
HOOK_ON_RACK = (0.01, 0.0, RACK_TOP + 0.003)
HOOK_ON_RACK_YAW = -math.pi / 2

# Pull and push: the tool heads along the block's face normal, with the tip frame 5 cm beyond the
# block's centre (pull: on its far side) or short of it (push: its near side) and 3 cm to its
# left, so that the hook's short part (x from 0.17 to 0.2 in the hook frame) meets the block's
# face with 1 cm to spare and the shaft passes 2.5 cm beside it. The action itself is expressed
# in the block's approach frame (gfc/sim/skills/tools.py), so ``stroke`` converts.
TIP_BEHIND = 0.05
TIP_SIDE = 0.03
TIP_GAP = 0.01  # m the block travels less than the hand: the gap closed before contact

# Blocks stand in a box with their y axis along the box's x axis (turned 90 degrees): the fingers
# close along the block's y axis, so they open along the box's long axis, where the slots leave
# room for them (columns 14 cm apart), never towards a neighbour 5.75 cm away in the same column.
BLOCK_IN_BOX_YAW = math.pi / 2
BOX_COLUMNS = (0.07, -0.07)  # the far column (box +x) first: the hand never reaches over a placed block
# 7.5 mm between neighbours and from the walls: the planner keeps placements PLACED_CLEARANCE
# (9 mm) apart and from the walls with a 2 mm sigma, which these slots meet within a sigma.
BOX_ROWS_3 = (-0.0575, 0.0, 0.0575)
BOX_ROWS_2 = (-0.045, 0.045)
# Placed blocks' footprints keep this much between them (the slots leave 7.5 mm).
BLOCK_CLEARANCE = 0.005


def hook_grasp() -> FloatArray:
    return grasp9(HOOK_GRASP)


def block_grasp() -> FloatArray:
    return grasp9([0.0, 0.0, BLOCK_GRASP_Z])


def block_in_box(x: float, y: float) -> FloatArray:
    """The place action of a block into a box slot (block pose in the box frame)."""
    return grasp9([x, y, FLOOR + 0.003], rot_z(BLOCK_IN_BOX_YAW))


def hook_on_rack() -> FloatArray:
    """The place action that lays the hook on the rack's bar (hook pose in the rack frame)."""
    return grasp9(HOOK_ON_RACK, rot_z(HOOK_ON_RACK_YAW))


def stroke(block_xy: Sequence[float], heading: float, block_travel: float, push: bool) -> FloatArray:
    """A pull (tip beyond the block) or a push (tip short of it) by the acting arm, the tool
    pointing along the world yaw ``heading``, that moves the block at ``block_xy`` (world)
    ``block_travel`` metres (along -heading for a pull, +heading for a push): ``(x, y, r, theta)``
    in the block's approach frame."""
    approach = approach_frame(RIGHT_BASE, [*block_xy, 0.0])
    theta = math.remainder(heading - math.atan2(approach[1, 0], approach[0, 0]), 2 * math.pi)
    tip = rot_z(theta)[:2, :2] @ np.array([-TIP_BEHIND if push else TIP_BEHIND, TIP_SIDE])
    return np.array([tip[0], tip[1], block_travel + TIP_GAP, theta])


def box_slots(rows: Sequence[Sequence[float]]) -> list[tuple[float, float]]:
    """Slots (box frame) column by column: ``rows[i]`` are the y values used in column ``i``."""
    return [(x, y) for x, ys in zip(BOX_COLUMNS, rows, strict=False) for y in ys]


def pick(obj: str) -> dict[str, object]:
    return {"skill": "pick", "robot": ROBOT, "object": obj}


def place(obj: str, target: str) -> dict[str, object]:
    return {"skill": "place", "robot": ROBOT, "object": obj, "target": target}


def tool(skill: str, target: str) -> dict[str, object]:
    return {"skill": skill, "robot": ROBOT, "object": "hook", "target": target}


def apart_pairs(names: Sequence[str], clearance: float = BLOCK_CLEARANCE) -> list[dict[str, object]]:
    """``apart`` between every pair at the end state: the packing's no-collision constraint.
    (Until session 12 ``far`` on the centres, 5.5 cm: turned blocks that far apart overlap, and
    most of GFC's packing candidates released a block into its neighbour.)"""
    return [
        {"type": "apart", "object": a, "target": b, "clearance": clearance}
        for i, a in enumerate(names)
        for b in names[i + 1 :]
    ]
