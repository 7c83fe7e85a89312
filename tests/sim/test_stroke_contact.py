"""The geometric contact model of push and pull (gfc.sim.skills.tools.stroke_contact): analytic
cases with known answers, its invariance to where the stroke happens, and its agreement with the
hook the simulator builds."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import assume, given
from hypothesis import strategies as st

from gfc import constraints
from gfc.geometry import FloatArray, matrix_to_pose9
from gfc.kinds import (
    HOOK_SHAFT_Y,
    HOOK_TIP_BAR_HALF_X,
    HOOK_TIP_BAR_Y,
    PIVOT_TRAVEL,
    STROKE_CLEARANCE,
    folded_turn,
    object_kind,
    pivot_shift,
)
from gfc.sim.bodies import recipe_for
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.skills.tools import stroke_contact, stroke_poses

HOOK = object_kind("hook")
BLOCK = object_kind("block").half_extents  # 2.5 cm half sides
TIP_X = HOOK.frame("tip")[0]  # 0.185 m along the hook


def _pose(x: float, y: float, yaw: float = 0.0) -> FloatArray:
    m = np.eye(4)
    c, s = math.cos(yaw), math.sin(yaw)
    m[:2, :2] = [[c, -s], [s, c]]
    m[:2, 3] = [x, y]
    return m


def test_the_constants_describe_the_hook_the_simulator_builds() -> None:
    shaft, tip = recipe_for("hook").parts
    assert tip.half[0] == pytest.approx(HOOK_TIP_BAR_HALF_X)
    assert tip.centre[0] == pytest.approx(TIP_X)
    assert (tip.centre[1] - tip.half[1], tip.centre[1] + tip.half[1]) == pytest.approx(HOOK_TIP_BAR_Y)
    assert (shaft.centre[1] - shaft.half[1], shaft.centre[1] + shaft.half[1]) == pytest.approx(HOOK_SHAFT_Y)


def test_a_pull_closes_its_gap_and_carries_the_block_the_rest() -> None:
    # The tasks' reference pull: the tip 5 cm beyond the block's centre, 3 cm to its side; the
    # bar's inner face (tip - 1.5 cm) is then 1 cm from the block's far face.
    block = _pose(TIP_X - 0.05, 0.02)
    contact = stroke_contact(HOOK, np.eye(4), BLOCK, block, r=0.26, sign=-1.0)
    assert contact.gap == pytest.approx(0.01)
    assert contact.travel == pytest.approx(0.25)
    moved = contact.moved(block, np.array([-1.0, 0.0, 0.0]))
    np.testing.assert_allclose(moved[:3, 3], [TIP_X - 0.30, 0.02, 0.0], atol=1e-12)


def test_a_push_meets_the_block_with_the_hooks_far_end() -> None:
    block = _pose(TIP_X + 0.05, 0.02)
    contact = stroke_contact(HOOK, np.eye(4), BLOCK, block, r=0.13, sign=1.0)
    assert contact.gap == pytest.approx(0.01)
    assert contact.travel == pytest.approx(0.12)


def test_a_turned_block_reaches_further_along_the_stroke() -> None:
    """At 30 degrees a 5 cm block reaches 2.5 (cos 30 + sin 30) cm from its centre: the gap
    shrinks."""
    turn = math.radians(30.0)
    block = _pose(TIP_X - 0.06, 0.02, turn)
    contact = stroke_contact(HOOK, np.eye(4), BLOCK, block, r=0.2, sign=-1.0)
    assert contact.gap == pytest.approx(
        0.06 - HOOK_TIP_BAR_HALF_X - 0.025 * (math.cos(turn) + math.sin(turn))
    )


def _pivoted(
    block: FloatArray, direction: FloatArray, travel: float, half: tuple[float, float]
) -> FloatArray:
    """Brute force: the box's corners, the one the face meets first (least along ``direction``),
    the face carried ``travel`` past it, the box turned flat with that corner where it met the
    face across the stroke. The centre's xy."""
    d = direction[:2] / np.linalg.norm(direction[:2])
    across = np.array([-d[1], d[0]])
    corners = [block[:2, :2] @ np.array([sx * half[0], sy * half[1]]) for sx in (-1, 1) for sy in (-1, 1)]
    lead = min(corners, key=lambda c: float(c @ d))
    turn = math.atan2(block[1, 0], block[0, 0]) - math.atan2(d[1], d[0])
    flat_yaw = math.atan2(block[1, 0], block[0, 0]) - folded_turn(turn)
    c, s = abs(math.cos(flat_yaw - math.atan2(d[1], d[0]))), abs(math.sin(flat_yaw - math.atan2(d[1], d[0])))
    along_half, across_half = half[0] * c + half[1] * s, half[0] * s + half[1] * c
    along = float(lead @ d) + travel + along_half
    side = float(lead @ across)
    return block[:2, 3] + along * d + (side - math.copysign(across_half, side)) * across


@pytest.mark.parametrize("yaw_deg", [-25.0, 10.0, 70.0, 110.0])
def test_a_block_met_askew_ends_flat_against_the_hooks_face(yaw_deg: float) -> None:
    """The face turns the block until they lie flat: its yaw ends at the tool's (0 here), a
    quarter turn being the same box, and its centre where the face leaves it, the corner it met
    staying where it met it across the stroke."""
    block = _pose(TIP_X - 0.07, 0.02, math.radians(yaw_deg))
    contact = stroke_contact(HOOK, np.eye(4), BLOCK, block, r=0.2, sign=-1.0)
    direction = np.array([-1.0, 0.0, 0.0])
    moved = contact.moved(block, direction)
    yaw = math.degrees(math.atan2(moved[1, 0], moved[0, 0]))
    assert yaw % 90.0 == pytest.approx(0.0, abs=1e-6) or yaw % 90.0 == pytest.approx(90.0, abs=1e-6)
    np.testing.assert_allclose(
        moved[:2, 3], _pivoted(block, direction, contact.travel, BLOCK[:2]), atol=1e-12
    )
    assert moved[2, 3] == block[2, 3]


def test_a_block_met_thirty_degrees_askew_ends_short_and_to_the_side() -> None:
    """The analytic case: a 5 cm block met 30 degrees askew by a push along +x. Its leading
    corner is 2.5 (cos 30 + sin 30) = 3.42 cm behind its centre and 2.5 (cos 30 - sin 30) =
    0.92 cm to its left; turned flat about it, the centre ends 0.92 cm short of sliding alone
    and 2.5 - 0.92 = 1.58 cm to the right."""
    along, across = pivot_shift(math.radians(30.0), 0.025, 0.025)
    assert along == pytest.approx(-0.025 * (math.cos(math.pi / 6) + math.sin(math.pi / 6) - 1.0))
    assert across == pytest.approx(-0.025 * (1.0 - math.cos(math.pi / 6) + math.sin(math.pi / 6)))
    assert pivot_shift(0.0, 0.025, 0.025) == (0.0, 0.0)
    # Mirror images: met the other way askew, it ends as far to the other side.
    assert pivot_shift(math.radians(-30.0), 0.025, 0.025) == pytest.approx((along, -across))


@given(
    yaw=st.floats(-math.pi, math.pi),
    heading=st.floats(-math.pi, math.pi),
    half=st.tuples(st.floats(0.01, 0.05), st.floats(0.01, 0.05)),
    travel=st.floats(PIVOT_TRAVEL, 0.3),
)
def test_the_pivot_shift_is_where_a_box_turned_about_its_leading_corner_ends(
    yaw: float, heading: float, half: tuple[float, float], travel: float
) -> None:
    """``pivot_shift`` (numpy, the screen) and the factor's batched copy against the brute force
    above, for any box, any heading of the stroke and any yaw within the hook's limit."""
    turn = yaw - heading
    assume(abs(folded_turn(turn)) < math.radians(40.0))
    block = _pose(0.3, -0.1, yaw)
    direction = np.array([math.cos(heading), math.sin(heading), 0.0])
    along, across = pivot_shift(turn, *half)
    perpendicular = np.array([-direction[1], direction[0]])
    ours = block[:2, 3] + (travel + along) * direction[:2] + across * perpendicular
    np.testing.assert_allclose(ours, _pivoted(block, direction, travel, half), atol=1e-7)
    extent = half[0] * abs(math.cos(turn)) + half[1] * abs(math.sin(turn))
    batched = constraints._pivot_shift(
        torch.tensor([turn], dtype=torch.float64), *half, torch.tensor([extent], dtype=torch.float64)
    )
    np.testing.assert_allclose([float(batched[0][0]), float(batched[1][0])], [along, across], atol=1e-12)


@pytest.mark.parametrize(
    ("block", "r", "sign", "failure", "words"),
    [
        (_pose(TIP_X - 0.05, 0.08), 0.2, -1.0, FailureType.PHYSICS, "off the hook's face"),
        (_pose(TIP_X - 0.05, -0.01), 0.2, -1.0, FailureType.PATH, "shaft would land on the target"),
        (_pose(TIP_X - 0.02, 0.02), 0.2, -1.0, FailureType.PATH, "lowered tool would land"),
        (_pose(TIP_X - 0.05, 0.02), 0.015, -1.0, FailureType.PHYSICS, "the stroke ends"),
        (_pose(TIP_X - 0.07, 0.02, math.radians(40.0)), 0.2, -1.0, FailureType.PHYSICS, "40 deg askew"),
        (_pose(TIP_X + 0.08, 0.0, math.radians(-50.0)), 0.2, 1.0, FailureType.PHYSICS, "40 deg askew"),
        (_pose(TIP_X + 0.15, 0.02), 0.1, 1.0, FailureType.PHYSICS, "the stroke ends"),
        # the bar's inner face 2 mm from the block: it would come down on the block's edge
        (
            _pose(TIP_X - HOOK_TIP_BAR_HALF_X - 0.002 - BLOCK[0], 0.02),
            0.2,
            -1.0,
            FailureType.PATH,
            "come down 0.2 cm",
        ),
    ],
    ids=[
        "off-the-face",
        "on-the-shaft",
        "under-the-tip",
        "too-short",
        "pull-askew",
        "push-askew",
        "push-too-far",
        "too-close",
    ],
)
def test_strokes_that_would_not_move_the_block_fail_with_their_reason(
    block: FloatArray, r: float, sign: float, failure: FailureType, words: str
) -> None:
    with pytest.raises(SkillFailure, match=words) as info:
        stroke_contact(HOOK, np.eye(4), BLOCK, block, r=r, sign=sign)
    assert info.value.failure_type == failure


@given(
    gap=st.floats(STROKE_CLEARANCE / 2 + 1e-6, 0.1),
    extra=st.floats(0.02, 0.15),
    side=st.floats(0.0, 0.04),
    x=st.floats(-1.0, 1.0),
    y=st.floats(-1.0, 1.0),
    yaw=st.floats(-math.pi, math.pi),
    pull=st.booleans(),
)
def test_contact_depends_only_on_where_the_block_is_relative_to_the_tool(
    gap: float, extra: float, side: float, x: float, y: float, yaw: float, pull: bool
) -> None:
    """Moving tool and block together anywhere on the table changes neither the gap nor the
    travel, and the travel is what the stroke has left once the gap is closed."""
    sign = -1.0 if pull else 1.0
    face = TIP_X - HOOK_TIP_BAR_HALF_X if pull else TIP_X + HOOK_TIP_BAR_HALF_X
    centre = face - gap - BLOCK[0] if pull else face + gap + BLOCK[0]
    block_in_tool = _pose(centre, side)
    world_from_tool = _pose(x, y, yaw)
    contact = stroke_contact(HOOK, world_from_tool, BLOCK, world_from_tool @ block_in_tool, gap + extra, sign)
    assert contact.gap == pytest.approx(gap, abs=1e-9)
    assert contact.travel == pytest.approx(extra, abs=1e-9)


@given(
    bx=st.floats(0.55, 0.85),
    by=st.floats(-0.5, 0.0),
    block_yaw=st.floats(-0.3, 0.3),
    x=st.floats(0.04, 0.08),
    y=st.floats(0.0, 0.05),
    r=st.floats(0.05, 0.3),
    theta=st.floats(-0.4, 0.4),
    pull=st.booleans(),
)
def test_the_planners_stroke_factor_says_what_the_screens_contact_model_says(
    bx: float, by: float, block_yaw: float, x: float, y: float, r: float, theta: float, pull: bool
) -> None:
    """Where the contact model slides the block (gfc.sim.skills.tools, used by the screen) is
    where the planner's implied ``stroke`` factor wants the effect node: zero residual there,
    and the residual grows by exactly the displacement elsewhere."""
    sign = -1.0 if pull else 1.0
    x = x if pull else -x  # the tip beyond the block for a pull, short of it for a push
    base = np.array([0.1, -0.35, 0.0])
    world_from_base = _pose(*base[:2])
    block = _pose(bx, by, block_yaw)
    action = np.array([x, y, r, theta])
    poses = stroke_poses(world_from_base, block, HOOK, np.eye(4), action, sign)
    try:
        contact = stroke_contact(HOOK, poses.world_from_tool, BLOCK, block, r, sign)
    except SkillFailure:
        assume(False)
        return
    after = contact.moved(block, poses.direction)
    params = {
        "sign": sign,
        "base": list(base),
        "tip": list(HOOK.frame("tip")[:3]),
        "bar_half_x": HOOK_TIP_BAR_HALF_X,
        "half_extents": list(BLOCK),
        "lateral": list(HOOK_TIP_BAR_Y) if pull else [HOOK_SHAFT_Y[0], HOOK_TIP_BAR_Y[1]],
    }

    def residual(end: FloatArray) -> np.ndarray:
        nodes = [torch.tensor(matrix_to_pose9(m), dtype=torch.float64).unsqueeze(0) for m in (block, end)]
        out = constraints.stroke([*nodes, torch.tensor(action, dtype=torch.float64).unsqueeze(0)], params)
        assert out.shape == (1, 4)
        return out[0].numpy()

    # The screen passes a tool lowered STROKE_CLEARANCE / 2 from the block; the factor wants
    # ``clearance`` (none by default).
    np.testing.assert_allclose(residual(after), [0.0, 0.0, 0.0, 0.0], atol=1e-9)
    params["clearance"] = STROKE_CLEARANCE
    np.testing.assert_allclose(residual(after)[3], max(0.0, STROKE_CLEARANCE - contact.gap), atol=1e-9)
    longest = {**params, "max_length": 0.1}  # the executor's longest stroke, here 10 cm
    nodes = [torch.tensor(matrix_to_pose9(m), dtype=torch.float64).unsqueeze(0) for m in (block, after)]
    out = constraints.stroke([*nodes, torch.tensor(action, dtype=torch.float64).unsqueeze(0)], longest)
    assert out.shape == (1, 5)
    assert float(out[0, 4]) == pytest.approx(max(0.0, r - 0.1), abs=1e-12)
    off = after.copy()
    off[:2, 3] += [0.03, -0.04]
    np.testing.assert_allclose(residual(off)[:2], [0.03, -0.04], atol=1e-9)
