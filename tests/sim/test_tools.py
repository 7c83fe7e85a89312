"""push and pull with the hook: the block moves the way the stroke goes, by contact only."""

from __future__ import annotations

import numpy as np
import pytest

from gfc.plan.schema import PlanRequest
from gfc.sim.execute import execute_plan
from gfc.sim.outcome import FailureType
from gfc.tasks.base import TABLE_Z, grasp9, pose7, robots_json

HOOK_GRASP = grasp9([-0.1, -0.045, 0.02])  # on the shaft, from above


def _plan(skill: str, block_x: float) -> PlanRequest:
    return PlanRequest.model_validate(
        {
            "scene": {
                "robots": robots_json(),
                "objects": [
                    {"name": "hook", "kind": "hook", "pose": pose7(0.35, 0.30, TABLE_Z)},
                    {"name": "block", "kind": "block", "pose": pose7(block_x, 0.42, TABLE_Z)},
                ],
            },
            "skeleton": [
                {"skill": "pick", "robot": "left", "object": "hook"},
                {"skill": skill, "robot": "left", "object": "hook", "target": "block"},
            ],
        }
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("skill", "block_x", "action", "direction"),
    [
        ("pull", 0.75, [0.05, 0.03, 0.15, 0.0], -1.0),  # the hook's end behind the block, drag it in
        ("push", 0.68, [-0.05, 0.03, 0.10, 0.0], 1.0),  # the hook's end in front, push it away
    ],
)
def test_stroke_moves_the_block_along_the_stroke(
    skill: str, block_x: float, action: list[float], direction: float
) -> None:
    outcome = execute_plan(_plan(skill, block_x), [HOOK_GRASP, np.array(action)], seed=0)
    assert all(s.success for s in outcome.steps), [s.reason for s in outcome.steps]
    moved = outcome.steps[-1].poses["block"][0] - block_x
    assert direction * moved > 0.05
    assert abs(outcome.steps[-1].poses["block"][1] - 0.42) < 0.03


def test_stroke_that_misses_the_block_is_type_3() -> None:
    outcome = execute_plan(_plan("pull", 0.75), [HOOK_GRASP, np.array([0.05, 0.20, 0.15, 0.0])], seed=0)
    failure = outcome.first_failure
    assert failure is not None and failure.step == 1
    assert failure.failure_type == FailureType.PHYSICS
    assert "did not move" in failure.reason
