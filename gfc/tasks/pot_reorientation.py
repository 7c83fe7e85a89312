"""Bimanual Pot Reorientation (paper, appendix): both arms grasp the pot's handles (one group),
lift it, and turn it about the vertical by a target angle (45 degrees by default) with both
hands at once (a second group). The two grasps must keep their relative pose throughout."""

from __future__ import annotations

import math

import numpy as np

from gfc.kinds import object_kind
from gfc.plan.schema import PlanRequest
from gfc.skills.signatures import PICK_LIFT
from gfc.tasks.base import (
    DOWN,
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

LIFT = PICK_LIFT  # m: the turn starts where the two-handed pick lifted the pot
HANDLE_GRASP_X = 0.03  # beside the bracket that joins the handle to the wall
DEFAULT_ANGLE_DEG = 45.0


def sample(seed: int) -> TaskInstance:
    return sample_with_angle(seed, DEFAULT_ANGLE_DEG)


def sample_with_angle(seed: int, angle_deg: float) -> TaskInstance:
    """A scene and reference actions that turn the pot by ``angle_deg`` (about +z, degrees)."""
    rng = np.random.default_rng(seed)
    px, py, yaw = 0.50 + rng.uniform(-0.02, 0.02), rng.uniform(-0.02, 0.02), rng.uniform(-0.1, 0.1)
    target_yaw = yaw + math.radians(angle_deg)
    plan = PlanRequest.model_validate(
        {
            "scene": {
                "robots": robots_json(),
                "objects": [{"name": "pot", "kind": "pot", "pose": pose7(px, py, TABLE_Z, yaw)}],
            },
            "skeleton": [
                {"skill": "pick", "robot": "left", "object": "pot", "group": "grasp"},
                {"skill": "pick", "robot": "right", "object": "pot", "group": "grasp"},
                {"skill": "move", "robot": "left", "object": "pot", "group": "turn"},
                {"skill": "move", "robot": "right", "object": "pot", "group": "turn"},
            ],
            "goal": [
                {
                    "type": "yaw",
                    "object": "pot",
                    "yaw_deg": math.degrees(math.atan2(math.sin(target_yaw), math.cos(target_yaw))),
                    "tolerance_deg": 5.0,
                }
            ],
            "options": {"seed": seed},
        }
    )
    handles = object_kind("pot").frames
    grasps = {
        side: grasp9([HANDLE_GRASP_X, handles[f"handle_{side}"][1], handles[f"handle_{side}"][2]], DOWN)
        for side in ("left", "right")
    }
    lifted = frame([px, py, TABLE_Z + LIFT], rot_z(yaw))
    # Turn about the pot's vertical axis: world_from_new = pivot @ Rz(angle) @ pivot^-1.
    pivot = frame([px, py, 0.0], np.eye(3))
    turn = pivot @ frame([0.0, 0.0, 0.0], rot_z(math.radians(angle_deg))) @ np.linalg.inv(pivot)
    turned = turn @ lifted  # the move's action: the pot's pose, in each arm's base frame
    actions = [grasps["left"], grasps["right"], in_base(LEFT_BASE, turned), in_base(RIGHT_BASE, turned)]
    return TaskInstance("pot_reorientation", seed, plan, list(actions))
