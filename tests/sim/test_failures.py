"""Perturbed parameters must fail with the right failure type, for the right reason."""

from __future__ import annotations

import numpy as np
import pytest

from gfc.geometry import matrix_to_pose9, pose9_to_matrix
from gfc.plan.schema import PlanRequest
from gfc.sim.execute import execute_plan
from gfc.sim.outcome import FailureType, PlanOutcome
from gfc.tasks import sample_task
from gfc.tasks.base import LEFT_BASE, RIGHT_BASE, frame, in_base

pytestmark = pytest.mark.slow


def _run(plan: PlanRequest, actions: list[np.ndarray | None], steps: int) -> PlanOutcome:
    """Execute the first ``steps`` steps of a plan."""
    head = plan.model_copy(update={"skeleton": plan.skeleton[:steps], "goal": []})
    return execute_plan(head, actions[:steps], seed=0)


def test_unreachable_move_target_is_type_1() -> None:
    instance = sample_task("hammer_place", 0)
    actions = list(instance.reference_actions)
    far = pose9_to_matrix(actions[5])
    far[:3, 3] = [1.4, -0.35, 0.3]  # 1.4 m in front of the left base: beyond a Panda's reach
    actions[5] = matrix_to_pose9(far)
    outcome = _run(instance.plan, actions, 6)
    failure = outcome.first_failure
    assert failure is not None and failure.step == 5
    assert failure.failure_type == FailureType.METHOD
    assert "no IK solution" in failure.reason


def test_grasp_off_the_object_is_type_1() -> None:
    instance = sample_task("hammer_place", 0)
    actions = list(instance.reference_actions)
    actions[0] = np.array([0.4, 0.0, 0.03, 1.0, 0.0, 0.0, 0.0, -1.0, 0.0])  # 24 cm beside the lid
    failure = _run(instance.plan, actions, 1).first_failure
    assert failure is not None and failure.failure_type == FailureType.METHOD
    assert "outside the lid" in failure.reason


def test_move_into_the_other_arm_is_type_2() -> None:
    """The right hand waits in the middle; the left hand is sent to the same place."""
    scene = sample_task("pot_reorientation", 0).plan.scene.model_copy(update={"objects": []})
    plan = PlanRequest.model_validate(
        {
            "scene": scene.model_dump(),
            "skeleton": [{"skill": "move", "robot": "right"}, {"skill": "move", "robot": "left"}],
        }
    )
    middle = frame([0.45, 0.0, 0.9], np.diag([1.0, -1.0, -1.0]))
    beside = middle.copy()
    beside[:3, 3] += [0.0, 0.02, 0.0]
    outcome = execute_plan(plan, [in_base(RIGHT_BASE, middle), in_base(LEFT_BASE, beside)], seed=0)
    assert outcome.steps[0].success, outcome.steps[0].reason
    failure = outcome.first_failure
    assert failure is not None and failure.step == 1
    assert failure.failure_type == FailureType.PATH
    assert "left with right" in failure.reason


def test_release_in_mid_air_is_type_3() -> None:
    """Placing the lid 15 cm above the tray: the gripper opens in the air and the lid drops."""
    instance = sample_task("hammer_place", 0)
    actions = list(instance.reference_actions)
    high = pose9_to_matrix(actions[1])
    high[2, 3] += 0.15
    actions[1] = matrix_to_pose9(high)
    failure = _run(instance.plan, actions, 2).first_failure
    assert failure is not None and failure.step == 1
    assert failure.failure_type == FailureType.PHYSICS
    assert "did not stay where it was released" in failure.reason


def test_strike_beside_the_nail_is_type_1() -> None:
    instance = sample_task("hammer_nail", 0)
    actions = list(instance.reference_actions)
    aside = pose9_to_matrix(actions[9])
    aside[:3, 3] += [0.06, 0.0, 0.0]
    actions[9] = matrix_to_pose9(aside)
    outcome = execute_plan(instance.plan, actions, seed=0)
    failure = outcome.first_failure
    assert failure is not None and failure.step == 10
    assert failure.failure_type == FailureType.METHOD
    assert not outcome.goal_satisfied


def test_pot_moves_that_break_the_grip_are_type_1() -> None:
    instance = sample_task("pot_reorientation", 0)
    actions = list(instance.reference_actions)
    apart = pose9_to_matrix(actions[3])
    apart[:3, 3] += [0.0, -0.05, 0.0]  # the right hand 5 cm away from where the pot's handle will be
    actions[3] = matrix_to_pose9(apart)
    failure = execute_plan(instance.plan, actions, seed=0).first_failure
    assert failure is not None and failure.step in (2, 3)
    assert failure.failure_type == FailureType.METHOD
    assert "fixed transform" in failure.reason


def test_wrong_action_size_is_type_1() -> None:
    instance = sample_task("pot_reorientation", 0)
    actions = list(instance.reference_actions)
    actions[0] = np.zeros(4)
    failure = execute_plan(instance.plan, actions, seed=0).first_failure
    assert failure is not None and failure.failure_type == FailureType.METHOD
    assert "needs 9" in failure.reason


def test_right_base_constant_matches_the_scene() -> None:
    instance = sample_task("hammer_place", 0)
    bases = {r.name: tuple(r.base) for r in instance.plan.scene.robots}
    assert bases == {"left": LEFT_BASE, "right": RIGHT_BASE}
