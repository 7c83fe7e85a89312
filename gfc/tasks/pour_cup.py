"""Pour Cup (paper: 4 stages): the left arm picks the mug (holding six beads), the right arm
picks the cup, both move at once (one group) to bring the mug's lip over the cup, and the left
arm pours. Success: the pour's precondition holds and the beads land in the cup.

The paper counts 4 steps; here the two moves are one group, so the skeleton has 5 entries in
4 stages (pick, pick, move+move, pour).
"""

from __future__ import annotations

import math

import numpy as np

from gfc.kinds import object_kind
from gfc.plan.schema import PlanRequest
from gfc.tasks.base import (
    LEFT_BASE,
    RIGHT_BASE,
    TABLE_Z,
    TaskInstance,
    frame,
    grasp9,
    in_base,
    pose7,
    robots_json,
    rot_z,
)

BEADS = 6
# m the lip stops short of the cup's centre: the contents leave it moving towards the cup.
LIP_SHORT = 0.0135
CLEARANCE = 0.035  # m between the cup's rim and the mug's bottom when the pour starts
_MUG, _CUP = object_kind("mug"), object_kind("cup")
assert _MUG.inner_half_extents is not None
MEET_OFFSET = round(_MUG.inner_half_extents[0] + 0.01, 3)  # m between the rims' centres, in xy
MEET_HEIGHT = round(_MUG.frames["rim"][2] + CLEARANCE, 3)  # m from the cup's rim up to the mug's
# Side grasps, fingers across the body, the hand's x axis up (columns: the hand's x, y, z axes).
# The mug is taken high, approaching along its -x (the handle on the far side); the cup low,
# approaching along its +y, so the two forearms come from different sides when they meet.
MUG_GRASP = grasp9([0.005, 0.0, 0.08], np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]).T)
CUP_GRASP = grasp9([0.0, -0.005, 0.046], np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).T)


def sample(seed: int) -> TaskInstance:
    rng = np.random.default_rng(seed)
    mug_yaw = math.pi + rng.uniform(-0.1, 0.1)  # handle away from the robots
    mug = pose7(0.505 + rng.uniform(-0.015, 0.015), 0.22 + rng.uniform(-0.02, 0.02), TABLE_Z, mug_yaw)
    cup = pose7(
        0.45 + rng.uniform(-0.03, 0.03), -0.25 + rng.uniform(-0.03, 0.03), TABLE_Z, rng.uniform(-0.3, 0.3)
    )
    plan = PlanRequest.model_validate(
        {
            "scene": {
                "robots": robots_json(),
                "objects": [
                    {"name": "mug", "kind": "mug", "pose": mug},
                    {"name": "cup", "kind": "cup", "pose": cup},
                ],
            },
            "skeleton": [
                {"skill": "pick", "robot": "left", "object": "mug"},
                {"skill": "pick", "robot": "right", "object": "cup"},
                {"skill": "move", "robot": "left", "object": "mug", "group": "meet"},
                {"skill": "move", "robot": "right", "object": "cup", "group": "meet"},
                {"skill": "pour", "robot": "left", "object": "mug", "target": "cup"},
            ],
            "constraints": [
                {
                    # The pour's precondition as a constraint: the mug's rim centre a little
                    # more than the mug's inner radius from the cup's (so its lip, the rim point
                    # towards the cup, is over the cup's opening) and high enough that the mug's
                    # bottom clears the cup's rim by CLEARANCE.
                    "type": "aligned",
                    "object": "mug",
                    "frame": "rim",
                    "target": "cup",
                    "target_frame": "rim",
                    "offset": MEET_OFFSET,
                    "height": MEET_HEIGHT,
                    "tolerance": 0.01,
                    "at": "meet",
                },
            ],
            "goal": [{"type": "near", "object": "mug", "target": "cup", "distance": 0.2}],
            "options": {"seed": seed},
        }
    )
    # Meeting point: the cup held up in front, the mug's lip (rim point towards the cup) right
    # above the cup's centre, the mug's bottom CLEARANCE above the cup's rim.
    cup_at = frame(
        [0.45 + rng.uniform(-0.03, 0.03), -0.06 + rng.uniform(-0.02, 0.02), TABLE_Z + 0.16], rot_z(0.0)
    )
    mug_inner = object_kind("mug").inner_half_extents
    assert mug_inner is not None
    cup_rim = object_kind("cup").frames["rim"][2]
    mug_at = frame(
        cup_at[:3, 3] + np.array([0.0, mug_inner[0] + LIP_SHORT, cup_rim + CLEARANCE]), rot_z(math.pi)
    )
    actions = [
        MUG_GRASP,
        CUP_GRASP,
        in_base(LEFT_BASE, mug_at),
        in_base(RIGHT_BASE, cup_at),
        None,
    ]
    return TaskInstance("pour_cup", seed, plan, list(actions), contents={"mug": BEADS})
