"""The pour's tipping motion (gfc.sim.skills.terminal.tipping_poses): pure geometry, no simulator."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gfc.sim.skills.terminal import POUR_ANGLE, POUR_LIP_AIM, PourAim, tipping_poses

RADIUS = 0.029  # m, the cup's inner half-width


def _lip_track(along: float, heading: float) -> tuple[PourAim, list[np.ndarray]]:
    """The lip's world position at every tipping pose, for a lip ``along`` metres past the
    target's centre along a pouring direction at ``heading`` radians."""
    direction = np.array([np.cos(heading), np.sin(heading), 0.0])
    target_rim = np.array([0.5, 0.1, 0.8])
    lip = target_rim + along * direction + np.array([0.0, 0.0, 0.05])
    aim = PourAim(lip, direction, target_rim, RADIUS)
    start = np.eye(4)
    start[:3, 3] = lip + np.array([0.0, 0.0, 0.08]) - 0.04 * direction  # the hand, above and behind
    poses = tipping_poses(aim, start, rim_height=0.1)
    lip_in_hand = np.linalg.inv(start) @ np.array([*lip, 1.0])
    return aim, [(pose @ lip_in_hand)[:3] for pose in poses]


def _along(aim: PourAim, point: np.ndarray) -> float:
    return float((point - aim.target_rim)[:2] @ aim.direction[:2])


@settings(max_examples=30, deadline=None)
@given(along=st.floats(POUR_LIP_AIM * RADIUS, 0.02), heading=st.floats(-np.pi, np.pi))
def test_a_lip_past_the_aim_is_drawn_back_to_it_by_the_time_the_source_is_level(
    along: float, heading: float
) -> None:
    aim, track = _lip_track(along, heading)
    assert abs(_along(aim, track[0]) - along) < 1e-9
    level = min(range(len(track)), key=lambda k: abs(k / (len(track) - 1) * POUR_ANGLE - np.pi / 2))
    assert abs(_along(aim, track[-1]) - POUR_LIP_AIM * RADIUS) < 1e-9
    assert abs(_along(aim, track[level]) - POUR_LIP_AIM * RADIUS) < 0.002  # nearest sample to 90 deg
    # drawn back monotonically, never sideways
    alongs = [_along(aim, p) for p in track]
    assert all(b <= a + 1e-12 for a, b in itertools.pairwise(alongs))
    sideways = np.array([-aim.direction[1], aim.direction[0]])
    assert all(abs(float((p - aim.target_rim)[:2] @ sideways)) < 1e-9 for p in track)


def test_a_lip_on_the_near_side_already_stays_where_it_is() -> None:
    aim, track = _lip_track(-0.025, 0.3)
    assert all(abs(_along(aim, p) + 0.025) < 1e-9 for p in track)


def test_the_lip_comes_down_to_its_lowest_over_the_rim_and_not_below() -> None:
    aim, track = _lip_track(0.0, 1.0)
    heights = [p[2] - aim.target_rim[2] for p in track]
    assert abs(heights[0] - 0.05) < 1e-9
    assert min(heights) > 0.0199  # POUR_LIP_LOW
    assert abs(heights[-1] - 0.02) < 1e-9
