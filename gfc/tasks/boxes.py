"""The lid-and-cube prelude shared by Hammer Place and Hammer Nail (paper, appendix): the cube
waits in a box under a lid; the left arm lifts the lid onto a second box and puts the cube on it.
These four steps are task-irrelevant distractions that a planner must still get right."""

from __future__ import annotations

import numpy as np

from gfc.geometry import FloatArray
from gfc.kinds import object_kind
from gfc.tasks.base import TABLE_Z, grasp9, pose7

FLOOR = 0.01  # m: thickness of a box's floor
_BOX_HEIGHT = 2 * object_kind("box").half_extents[2]


def prelude_objects(rng: np.random.Generator) -> list[dict[str, object]]:
    """Objects of the prelude, jittered by a few centimetres per seed."""
    bx, by = 0.50 + rng.uniform(-0.02, 0.02), 0.62 + rng.uniform(-0.02, 0.02)
    sx, sy = 0.62 + rng.uniform(-0.02, 0.02), 0.30 + rng.uniform(-0.02, 0.02)
    cx, cy = bx + rng.uniform(-0.05, 0.05), by + rng.uniform(-0.03, 0.03)
    return [
        {"name": "bin", "kind": "box", "pose": pose7(bx, by, TABLE_Z), "fixed": True},
        {"name": "lid", "kind": "lid", "pose": pose7(bx, by, TABLE_Z + _BOX_HEIGHT)},
        {
            "name": "cube",
            "kind": "cube",
            "pose": pose7(cx, cy, TABLE_Z + FLOOR, rng.uniform(-0.3, 0.3)),
        },
        {"name": "tray", "kind": "box", "pose": pose7(sx, sy, TABLE_Z), "fixed": True},
    ]


def prelude_skeleton() -> list[dict[str, object]]:
    return [
        {"skill": "pick", "robot": "left", "object": "lid"},
        {"skill": "place", "robot": "left", "object": "lid", "target": "tray"},
        {"skill": "pick", "robot": "left", "object": "cube"},
        {"skill": "place", "robot": "left", "object": "cube", "target": "lid"},
    ]


def prelude_actions() -> list[FloatArray | None]:
    knob_z = object_kind("lid").frames["knob"][2]
    return [
        grasp9([0.0, 0.0, knob_z]),  # the knob, from above
        grasp9([0.0, 0.0, _BOX_HEIGHT + 0.003], np.eye(3)),  # the lid on the tray's rim
        grasp9([0.0, 0.0, 0.025]),  # the cube, from above
        grasp9([0.09, 0.0, 0.013], np.eye(3)),  # the cube on the lid's plate, beside the knob
    ]
