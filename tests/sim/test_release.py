"""Letting go at a placement (gfc.sim.skills.placing): the fingers open only a little off the
object, and a symmetric block is put down turned where its fingers would meet a neighbour."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gfc.geometry import pose7_to_matrix, pose9_to_matrix
from gfc.sim import control
from gfc.sim.execute import execute_plan
from gfc.sim.panda import FINGER_MAX
from gfc.sim.skills import placing
from gfc.sim.skills.placing import RELEASE_TRAVEL
from gfc.sim.world import World
from tests.sim.block_to_box import BLOCK, BOX, block_to_box_plan


def _finger_axis(actions: list[np.ndarray]) -> np.ndarray:
    """The commanded hand's finger axis (its y axis) at the placement, box frame (xy)."""
    grasp, placement = actions
    hand = pose9_to_matrix(placement) @ pose9_to_matrix(grasp)
    axis: np.ndarray = hand[:2, 1] / np.linalg.norm(hand[:2, 1])
    return axis


@pytest.mark.slow
def test_a_block_is_put_down_turned_where_the_fingers_would_meet_its_neighbour(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The neighbour sits 1.2 cm from the placed block along the commanded fingers' axis: a
    finger (about 1 cm thick) opening beside it would press into it. The executor puts the
    cube down turned by a quarter turn (the same footprint), fingers along the free axis, lets
    go with the fingers RELEASE_TRAVEL off the block, and the neighbour stays where it was."""
    _, actions = block_to_box_plan(np.zeros(3))
    axis = _finger_axis(actions)
    offset = np.array([*(axis * (BLOCK + 0.012)), 0.0])
    plan, actions = block_to_box_plan(offset)
    releases: list[float] = []

    def open_gripper(world: World, robot: str, steps: int = 60, finger: float = FINGER_MAX) -> None:
        releases.append(finger)
        control.open_gripper(world, robot, steps, finger)

    monkeypatch.setattr(placing, "open_gripper", open_gripper)
    outcome = execute_plan(plan, actions, seed=0)
    assert outcome.success, outcome.steps[-1].reason
    place = outcome.steps[-1]
    hand = pose7_to_matrix(place.poses["right"])
    box = pose7_to_matrix(BOX)
    hand_axis = (np.linalg.inv(box) @ hand)[:2, 1]
    turn = math.degrees(math.acos(min(1.0, abs(float(hand_axis @ axis)) / np.linalg.norm(hand_axis))))
    assert turn > 80.0, f"the fingers stayed along the neighbour's axis ({turn:.0f} deg turned)"
    start = outcome.steps[0].poses["neighbour"]
    assert np.linalg.norm(np.subtract(place.poses["neighbour"][:3], start[:3])) < 0.003
    # Let go a little (the block's width and RELEASE_TRAVEL a side, not 4 cm a finger), then,
    # clear of the box after the retreat, open fully.
    assert releases[0] < BLOCK / 2 + RELEASE_TRAVEL + 0.01
    assert releases[-1] == FINGER_MAX
    assert place.grippers["right"] > 0.07


@pytest.mark.slow
def test_a_placement_with_room_for_the_fingers_is_put_down_as_commanded() -> None:
    _, actions = block_to_box_plan(np.zeros(3))
    axis = _finger_axis(actions)
    across = np.array([-axis[1], axis[0]])  # the neighbour beside it, off the fingers' axis
    plan, actions = block_to_box_plan(np.array([*(across * (BLOCK + 0.012)), 0.0]))
    outcome = execute_plan(plan, actions, seed=0)
    assert outcome.success, outcome.steps[-1].reason
    hand_axis = (np.linalg.inv(pose7_to_matrix(BOX)) @ pose7_to_matrix(outcome.steps[-1].poses["right"]))[
        :2, 1
    ]
    assert abs(float(hand_axis @ axis)) / np.linalg.norm(hand_axis) > math.cos(math.radians(10.0))
