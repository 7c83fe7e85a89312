"""Hammer Place (paper: 8 steps): after the lid-and-cube prelude, the left arm picks the hammer
near its head and holds it out, the right arm takes it by the handle end and puts it in the box
on the right, which the left arm cannot reach."""

from __future__ import annotations

import math

import numpy as np

from gfc.plan.schema import PlanRequest
from gfc.tasks.base import (
    LEFT_BASE,
    TABLE_Z,
    TaskInstance,
    frame,
    grasp9,
    in_base,
    pose7,
    robots_json,
    rot_z,
)
from gfc.tasks.boxes import FLOOR, prelude_actions, prelude_objects, prelude_skeleton

HANDLE_Z = 0.018  # m: grasp height on the handle (its centre is at 0.0125; fingertips clear the table)
LEFT_GRASP_X = 0.03  # near the head
RIGHT_GRASP_X = -0.08  # near the handle end


def handover_pose(rng: np.random.Generator) -> np.ndarray:
    """World pose of the hammer when the left hand holds it out, handle towards -y."""
    return frame(
        [0.45 + rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.02), TABLE_Z + 0.25],
        rot_z(math.pi / 2),
    )


def hammer_objects(rng: np.random.Generator) -> list[dict[str, object]]:
    hx, hy = 0.30 + rng.uniform(-0.03, 0.03), 0.12 + rng.uniform(-0.03, 0.03)
    return [
        {
            "name": "hammer",
            "kind": "hammer",
            "pose": pose7(hx, hy, TABLE_Z, rng.uniform(-0.25, 0.25)),
        }
    ]


def hammer_handover_skeleton() -> list[dict[str, object]]:
    return [
        {"skill": "pick", "robot": "left", "object": "hammer"},
        {"skill": "move", "robot": "left", "object": "hammer"},
        {"skill": "regrasp", "robot": "right", "object": "hammer", "from": "left"},
    ]


def sample(seed: int) -> TaskInstance:
    rng = np.random.default_rng(seed)
    bx, by = 0.50 + rng.uniform(-0.03, 0.03), -0.50 + rng.uniform(-0.03, 0.03)
    objects = [
        *prelude_objects(rng),
        *hammer_objects(rng),
        {
            "name": "box",
            "kind": "box",
            "pose": pose7(bx, by, TABLE_Z, rng.uniform(-0.15, 0.15)),
            "fixed": True,
        },
    ]
    plan = PlanRequest.model_validate(
        {
            "scene": {"robots": robots_json(), "objects": objects},
            "skeleton": [
                *prelude_skeleton(),
                *hammer_handover_skeleton(),
                {"skill": "place", "robot": "right", "object": "hammer", "target": "box"},
            ],
            "goal": [{"type": "inside", "object": "hammer", "target": "box"}],
            "options": {"seed": seed},
        }
    )
    actions = [
        *prelude_actions(),
        grasp9([LEFT_GRASP_X, 0.0, HANDLE_Z]),
        in_base(LEFT_BASE, handover_pose(rng)),
        grasp9([RIGHT_GRASP_X, 0.0, HANDLE_Z]),
        grasp9([0.0, 0.0, FLOOR + 0.004], np.eye(3)),
    ]
    return TaskInstance("hammer_place", seed, plan, actions)
