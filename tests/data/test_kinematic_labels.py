"""Kinematically labelled pre-states (a pour's): every kept row satisfies the pour's geometric
precondition, and a row realised back into set-up actions walks to the same pre-state."""

from __future__ import annotations

import numpy as np
import pytest

from gfc.data.collect import Attempt, robot_frame_map, run_attempt, run_kinematic
from gfc.data.scenarios import SCENARIOS
from gfc.geometry import pose9_to_matrix
from gfc.kinds import object_kind
from gfc.sim.skills.terminal import aim_pour
from gfc.skills.check import realise_pre_state

SEEDS = range(12)


@pytest.fixture(scope="module")
def labelled() -> list[tuple[int, dict[str, object]]]:
    return [(seed, run_attempt(Attempt("pour.mug.cup", seed))) for seed in SEEDS]


@pytest.mark.slow
def test_kept_pre_states_hold_the_pours_precondition(labelled: list[tuple[int, dict[str, object]]]) -> None:
    kept = [(seed, r) for seed, r in labelled if r["status"] == "success"]
    failed = [r for _, r in labelled if r["status"] == "failure"]
    assert kept and failed  # the random meetings are neither all feasible nor all not
    assert all(r["failure_type"] == "kinematic" and r["reason"] for r in failed)
    mug, cup = object_kind("mug"), object_kind("cup")
    for seed, result in kept:
        (row,) = np.asarray(result["rows"])  # type: ignore[call-overload]
        assert row.shape == (28,)  # hand (9 + gripper), mug (9), cup (9)
        scenario = SCENARIOS["pour.mug.cup"](np.random.default_rng(seed))
        pourer = scenario.plan.skeleton[-1].robot
        a, b = robot_frame_map(scenario.plan, pourer)
        world = [pose9_to_matrix(a.T @ (row[s] - b)) for s in (slice(10, 19), slice(19, 28))]
        aim_pour(mug, world[0], cup, world[1], "mug", "cup")  # raises if the precondition fails
        assert 0.04 < row[9] < 0.08  # fingers closed on a 7 cm mug


@pytest.mark.slow
def test_a_realised_pre_state_walks_back_to_itself(labelled: list[tuple[int, dict[str, object]]]) -> None:
    seed, result = next((s, r) for s, r in labelled if r["status"] == "success")
    (row,) = np.asarray(result["rows"])  # type: ignore[call-overload]
    scenario = SCENARIOS["pour.mug.cup"](np.random.default_rng(seed))
    again = run_kinematic(scenario, seed, realise_pre_state(scenario, row))
    assert again["status"] == "success", again.get("reason")
    (row2,) = np.asarray(again["rows"])  # type: ignore[call-overload]
    for token in (slice(0, 3), slice(10, 13), slice(19, 22)):  # positions: hand, mug, cup
        assert np.allclose(row2[token], row[token], atol=2e-3)
    for token in (slice(3, 9), slice(13, 19), slice(22, 28)):  # rotation columns
        assert np.allclose(row2[token], row[token], atol=2e-2)


def test_kinematic_labels_refuse_a_step_with_an_action() -> None:
    scenario = SCENARIOS["move.mug"](np.random.default_rng(0))
    with pytest.raises(ValueError, match="action-less"):
        run_kinematic(scenario, 0)
