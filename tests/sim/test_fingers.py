"""The Panda's fingers are geared to move as one (gfc.sim.panda.couple_fingers, ADR 0011): pulled
apart they come back together, and a block gripped off the hand's centre is pushed to it, so
the hand lets go of it without a sideways spring."""

from __future__ import annotations

import numpy as np
import pybullet as pb
import pytest

from gfc.plan.schema import PlanRequest
from gfc.sim import control
from gfc.sim.execute import execute_plan
from gfc.sim.panda import FINGER_JOINTS, FINGER_MAX, command_fingers, finger_positions
from gfc.sim.skills import placing
from gfc.sim.world import World, step
from tests.sim.block_to_box import block_to_box_plan


def test_fingers_set_apart_end_level(hammer_place_world: tuple[World, PlanRequest]) -> None:
    world, _ = hammer_place_world
    robot = world.physics.robots["left"]
    pb.resetJointState(robot.body, FINGER_JOINTS[0], 0.01, physicsClientId=world.client)
    pb.resetJointState(robot.body, FINGER_JOINTS[1], 0.035, physicsClientId=world.client)
    command_fingers(world.client, robot, 0.02)
    step(world, 240)
    left, right = finger_positions(world.client, robot)
    assert abs(left - right) < 0.002, (left, right)
    assert abs(left - 0.02) < 0.003, (left, right)


def _pick_and_place(grasp_shift: float) -> tuple[bool, str, tuple[float, float]]:
    """Pick a block with the hand ``grasp_shift`` m off its centre along the fingers' axis and
    place it in the box; returns success, the last step's reason and the fingers at release."""
    plan, (grasp, placement) = block_to_box_plan()
    grasp[1] += grasp_shift  # the grasp's translation, y: along the fingers
    fingers: list[tuple[float, float]] = []

    def open_gripper(world: World, robot: str, steps: int = 60, finger: float = FINGER_MAX) -> None:
        fingers.append(finger_positions(world.client, world.physics.robots[robot]))
        control.open_gripper(world, robot, steps, finger)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(placing, "open_gripper", open_gripper)
        outcome = execute_plan(plan, [grasp, placement], seed=0)
    return outcome.success, outcome.steps[-1].reason, fingers[0]


@pytest.mark.slow
@pytest.mark.parametrize("grasp_shift", [0.012, -0.012])
def test_a_block_gripped_off_centre_is_centred_and_let_go_cleanly(grasp_shift: float) -> None:
    """Independent fingers held this block with one finger at its 4 cm limit and the other at
    1.2 cm; geared, both sit at about half the block's width."""
    success, reason, (left, right) = _pick_and_place(grasp_shift)
    assert success, reason
    assert abs(left - right) < 0.003, (left, right)
    assert np.isclose(left + right, 0.05, atol=0.004), (left, right)


def test_build_world_couples_each_robot(hammer_place_world: tuple[World, PlanRequest]) -> None:
    world, _ = hammer_place_world
    gears = [
        pb.getConstraintInfo(
            pb.getConstraintUniqueId(i, physicsClientId=world.client), physicsClientId=world.client
        )
        for i in range(pb.getNumConstraints(physicsClientId=world.client))
    ]
    geared_bodies = {info[0] for info in gears if info[4] == pb.JOINT_GEAR}
    assert geared_bodies == {r.body for r in world.physics.robots.values()}
