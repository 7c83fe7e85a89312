"""A pour with the holding hand between source and target pours onto the hand: the screen's
``palm_clear`` refuses it (ADR 0013). Pure geometry on the Pour Cup meeting, no simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gfc.geometry import FloatArray, pose9_to_matrix
from gfc.kinds import object_kind
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.skills.terminal import PourAim, aim_pour, palm_clear
from gfc.skills.signatures import POUR_PALM_TOWARDS
from gfc.tasks.base import frame, rot_z
from gfc.tasks.pour_cup import CLEARANCE, LIP_SHORT, MUG_GRASP

MUG, CUP = object_kind("mug"), object_kind("cup")
CUP_AT = frame([0.45, -0.06, 0.8], rot_z(0.0))


def _meeting(side: float, mug_yaw: float) -> tuple[PourAim, FloatArray]:
    """The mug's lip over the cup, the mug on the side of the cup at angle ``side`` (radians
    about the vertical; pi/2 is the task's reference, the pour then runs along -y), turned to
    ``mug_yaw``; the left hand holds it with the task's grasp. Returns the aim and the hand."""
    assert MUG.inner_half_extents is not None
    offset = MUG.inner_half_extents[0] + LIP_SHORT
    rim = CUP.frames["rim"][2] + CLEARANCE
    mug_at = frame(
        CUP_AT[:3, 3] + np.array([offset * math.cos(side), offset * math.sin(side), rim]), rot_z(mug_yaw)
    )
    aim = aim_pour(MUG, mug_at, CUP, CUP_AT, "mug", "cup")
    return aim, mug_at @ pose9_to_matrix(np.asarray(MUG_GRASP))


def _mug_beside_the_cup(dz: float) -> FloatArray:
    """The task's reference meeting (the lip over the cup), the mug ``dz`` higher."""
    assert MUG.inner_half_extents is not None
    offset = MUG.inner_half_extents[0] + LIP_SHORT
    return frame(
        CUP_AT[:3, 3] + np.array([0.0, offset, CUP.frames["rim"][2] + CLEARANCE + dz]), rot_z(math.pi)
    )


def test_a_pour_from_below_the_rim_is_refused() -> None:
    """The pour's precondition: the source's bottom above the target's rim."""
    aim_pour(MUG, _mug_beside_the_cup(0.0), CUP, CUP_AT, "mug", "cup")
    with pytest.raises(SkillFailure, match="above cup's rim") as refused:
        aim_pour(MUG, _mug_beside_the_cup(-0.10), CUP, CUP_AT, "mug", "cup")
    assert refused.value.failure_type is FailureType.METHOD


def test_the_reference_meeting_holds_the_mug_side_on() -> None:
    aim, hand = _meeting(math.pi / 2, math.pi)  # the task's reference: hand approach +x, pour -y
    assert np.allclose(aim.direction, [0.0, -1.0, 0.0], atol=1e-9)
    assert abs(hand[:3, 2] @ aim.direction) < 1e-9
    palm_clear(aim, hand, "mug", "cup")


def test_a_palm_towards_the_target_is_refused() -> None:
    aim, hand = _meeting(0.0, math.pi)  # the mug beyond the cup in x: the pour runs along -x
    assert hand[:3, 2] @ aim.direction == pytest.approx(-1.0)
    with pytest.raises(SkillFailure) as failure:
        palm_clear(aim, hand, "mug", "cup")
    assert failure.value.failure_type == FailureType.METHOD
    assert "between it and cup" in str(failure.value) and "180 degrees" in str(failure.value)


def test_a_hand_behind_the_source_passes() -> None:
    aim, hand = _meeting(math.pi, math.pi)  # the mug in front of the cup: the pour runs along +x
    assert hand[:3, 2] @ aim.direction == pytest.approx(1.0)
    palm_clear(aim, hand, "mug", "cup")


def test_a_hand_from_above_is_on_no_side() -> None:
    aim, _ = _meeting(math.pi / 2, math.pi)
    top = np.eye(4)
    top[:3, :3] = np.diag([1.0, -1.0, -1.0])  # approach straight down
    palm_clear(aim, top, "mug", "cup")


@given(st.floats(-math.pi, math.pi), st.floats(-0.6, 0.6))
def test_refused_exactly_when_the_approach_points_away_from_the_target(yaw: float, pitch: float) -> None:
    aim, _ = _meeting(math.pi / 2, math.pi)
    approach = np.array([math.cos(yaw) * math.cos(pitch), math.sin(yaw) * math.cos(pitch), -math.sin(pitch)])
    hand = np.eye(4)
    hand[:3, 2] = approach  # only the approach (z axis) matters
    towards = math.cos(yaw) * aim.direction[0] + math.sin(yaw) * aim.direction[1]
    if abs(towards - POUR_PALM_TOWARDS) < 1e-9:
        return
    if towards < POUR_PALM_TOWARDS:
        with pytest.raises(SkillFailure):
            palm_clear(aim, hand, "mug", "cup")
    else:
        palm_clear(aim, hand, "mug", "cup")
