"""The scene of the release and finger tests: one block picked from the table and placed in a
box, optionally beside a neighbour already resting in the box."""

from __future__ import annotations

import numpy as np

from gfc.geometry import pose7_to_matrix
from gfc.plan.schema import PlanRequest
from gfc.tasks.base import TABLE_Z, pose7, robots_json
from gfc.tasks.single_arm import block_grasp, block_in_box

BLOCK = 0.05  # m, the block's size
BOX = pose7(0.48, -0.12, TABLE_Z, 0.0)


def block_to_box_plan(neighbour_offset: np.ndarray | None = None) -> tuple[PlanRequest, list[np.ndarray]]:
    """Pick ``block`` from the table and place it in the box with the reference actions;
    ``neighbour`` (when an offset is given) rests in the box at ``neighbour_offset`` (box
    frame, m) from the placement."""
    grasp, placement = block_grasp(), block_in_box(0.0, 0.0)
    objects: list[dict[str, object]] = [
        {"name": "box", "kind": "box", "pose": BOX, "fixed": True},
        {"name": "block", "kind": "block", "pose": pose7(0.45, -0.46, TABLE_Z)},
    ]
    if neighbour_offset is not None:
        neighbour = placement[:3] + neighbour_offset
        position = (pose7_to_matrix(BOX) @ [*neighbour, 1.0])[:3]
        objects.append(
            {"name": "neighbour", "kind": "block", "pose": [float(v) for v in position] + [0, 0, 0, 1]}
        )
    plan = PlanRequest.model_validate(
        {
            "scene": {"robots": robots_json(), "objects": objects},
            "skeleton": [
                {"skill": "pick", "robot": "right", "object": "block"},
                {"skill": "place", "robot": "right", "object": "block", "target": "box"},
            ],
        }
    )
    return plan, [grasp, placement]
