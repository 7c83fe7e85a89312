"""Letting go at a placement (gfc.sim.skills.placing): the fingers open only a little off the
object, and a symmetric block is put down turned where its fingers would meet a neighbour."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gfc.geometry import pose7_to_matrix, pose9_to_matrix
from gfc.sim import control
from gfc.sim.execute import execute_in_world, execute_plan
from gfc.sim.panda import FINGER_MAX, finger_opening
from gfc.sim.skills import placing
from gfc.sim.skills.motions import SkillContext
from gfc.sim.skills.placing import RELEASE_TRAVEL
from gfc.sim.world import World, build_world
from gfc.tasks import sample_task
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


# Hook Reach T1 seed 45, independent sampling's top-1 (log docs/bench/trials/single_arm_s22_c0ef14c_hook.jsonl):
# pick the hook, pull the block, lay the hook on the rack at the edge of the arm's workspace.
_HOOK_TO_THE_RACK = [
    [-0.09249, -0.046885, 0.018509, -0.999913, -0.012354, -0.004703, -0.01233, 0.999911, -0.005007],
    [0.045136, 0.033439, 0.150113, 0.145005],
    [-0.03935, 0.020914, 0.122781, -0.048068, 0.998844, -0.00055, -0.998844, -0.048068, -0.000501],
]


@pytest.mark.slow
def test_a_hand_that_cannot_lift_straight_off_a_placement_goes_back_the_way_it_came() -> None:
    """At the rack the released hand has no IK solution for the top of a straight lift
    ("cannot move in a straight line to the retreat" until session 22, though the hand had come
    down that line); it retraces the descent's joint path instead and ends above the hook."""
    instance = sample_task("hook_reach_t1", 45)
    plan = instance.plan.model_copy(update={"skeleton": instance.plan.skeleton[:3], "goal": []})
    outcome = execute_plan(plan, [np.asarray(a) for a in _HOOK_TO_THE_RACK], seed=45)
    assert [s.success for s in outcome.steps] == [True, True, True], outcome.steps[-1].reason
    hand, hook = outcome.steps[-1].poses["right"], outcome.steps[-1].poses["hook"]
    assert hand[2] - hook[2] > placing.PLACE_APPROACH


# Constrained Packing T1 seed 35: GFC's top-1 pick and placement of block_0 (trial log
# docs/bench/trials/single_arm_s19.jsonl): the block is set down 5 mm above the box floor,
# turned a few degrees in the grip.
_JAMMED_BLOCK = (
    [-0.004809, -0.003332, 0.028823, -0.005005, 0.999987, 0.000813, 0.999925, 0.004996, 0.011195],
    [0.038354, -0.037869, 0.015401, -0.994529, 0.104463, 0.000666, -0.104463, -0.994529, -1.4e-05],
)


def _first_placement(seed: int) -> tuple[object, list[np.ndarray]]:
    instance = sample_task("constrained_packing_t1", seed)
    plan = instance.plan.model_copy(
        update={"skeleton": instance.plan.skeleton[:2], "goal": [], "constraints": []}
    )
    return plan, [np.asarray(a) for a in _JAMMED_BLOCK]


@pytest.mark.slow
def test_the_placement_that_jammed_on_stale_contacts_lets_go_at_the_drives_force(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """With Bullet's default contact breaking threshold (2 cm) this placement stayed wedged at
    40 and 70 N and the retreat lifted the block 8 cm; the wedge was contact points cached from
    the block's earlier poses in the grip (ADR 0015). With fresh contacts the fingers let go at
    the drive's force: the rescue below is not called on."""
    forces: list[float] = []

    def command_fingers(client: int, robot: object, finger: float, force: float = 40.0) -> None:
        forces.append(force)
        control_fingers(client, robot, finger, force)

    control_fingers = placing.command_fingers
    monkeypatch.setattr(placing, "command_fingers", command_fingers)
    plan, actions = _first_placement(35)
    outcome = execute_plan(plan, actions, seed=35)  # type: ignore[arg-type]
    assert outcome.success, outcome.steps[-1].reason
    assert placing.JAMMED_RELEASE_FORCE not in forces


@pytest.mark.slow
def test_fingers_still_pressing_on_the_object_alone_are_opened_at_the_hands_peak_force() -> None:
    """The rescue itself: fingers that still press on what they were told to let go of, and on
    nothing else, are opened at 140 N (here: the block held in the air after its pick)."""
    plan, actions = _first_placement(35)
    pick_only = plan.model_copy(update={"skeleton": plan.skeleton[:1]})  # type: ignore[attr-defined]
    with build_world(pick_only.scene) as world:
        assert execute_in_world(world, pick_only, actions[:1], seed=35).success
        panda = world.physics.robots["right"]
        held = finger_opening(world.client, panda)
        ctx = SkillContext(world, np.random.default_rng(0))
        placing._free_jammed_fingers(ctx, "right", "block_0", placing.release_finger(ctx, "right"))
        assert ctx.notes == [
            f"right's fingers were jammed on block_0: opened at {placing.JAMMED_RELEASE_FORCE:.0f} N"
        ]
        assert finger_opening(world.client, panda) > held + RELEASE_TRAVEL
