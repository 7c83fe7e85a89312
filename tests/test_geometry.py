"""Poses, frames and the spatial-factor residuals: analytic cases and properties."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from gfc import constraints
from gfc.geometry import (
    approach_frame,
    invert,
    matrix_to_pose9,
    matrix_to_quat,
    pose7_to_matrix,
    pose9_frame_map,
    pose9_to_matrix,
    quat_to_matrix,
    yaw_quat,
)

unit = st.floats(-1.0, 1.0, allow_nan=False)
coords = st.floats(-2.0, 2.0, allow_nan=False)


@st.composite
def poses(draw: st.DrawFn) -> np.ndarray:
    q = np.array([draw(unit) for _ in range(4)])
    if np.linalg.norm(q) < 0.1:
        q = np.array([0.0, 0.0, 0.0, 1.0])
    q /= np.linalg.norm(q)
    return np.concatenate([[draw(coords) for _ in range(3)], q])


@given(poses())
def test_quaternion_matrix_round_trip(pose: np.ndarray) -> None:
    rot = quat_to_matrix(pose[3:])
    assert np.allclose(rot @ rot.T, np.eye(3), atol=1e-9)
    q = matrix_to_quat(rot)
    assert np.allclose(quat_to_matrix(q), rot, atol=1e-9)
    assert q[3] >= 0  # canonical sign


@given(poses())
def test_pose9_round_trip(pose: np.ndarray) -> None:
    mat = pose7_to_matrix(pose)
    assert np.allclose(pose9_to_matrix(matrix_to_pose9(mat)), mat, atol=1e-9)


@given(poses(), poses())
def test_frame_map_is_the_linear_change_of_frame(
    world_from_base: np.ndarray, world_from_obj: np.ndarray
) -> None:
    """``A v + b`` on the 9-vector equals ``inv(world_from_base) @ world_from_obj``; A is orthogonal."""
    base, obj = pose7_to_matrix(world_from_base), pose7_to_matrix(world_from_obj)
    a, b = pose9_frame_map(base)
    assert np.allclose(a @ a.T, np.eye(9), atol=1e-9)
    expected = matrix_to_pose9(invert(base) @ obj)
    assert np.allclose(a @ matrix_to_pose9(obj) + b, expected, atol=1e-9)


def _node(x: float, y: float, z: float, yaw: float = 0.0) -> torch.Tensor:
    return torch.tensor(
        matrix_to_pose9(pose7_to_matrix([x, y, z, *yaw_quat(yaw)])), dtype=torch.float64
    ).unsqueeze(0)


def test_approach_frame_points_from_the_origin_to_the_target() -> None:
    frame = approach_frame([0.0, -0.35, 0.1], [0.5, 0.15, 0.02])
    assert np.allclose(frame[:3, 3], [0.5, 0.15, 0.02])  # at the target, its height kept
    assert np.allclose(frame[:3, 0], [math.sqrt(0.5), math.sqrt(0.5), 0.0])  # 45 degrees
    assert np.allclose(frame[:3, 2], [0.0, 0.0, 1.0])
    assert np.allclose(frame[:3, :3] @ frame[:3, :3].T, np.eye(3))


@given(coords, coords, coords, coords)
def test_approach_frame_x_axis_is_the_unit_bearing(ox: float, oy: float, tx: float, ty: float) -> None:
    bearing = np.array([tx - ox, ty - oy])
    if np.linalg.norm(bearing) < 1e-3:
        return
    frame = approach_frame([ox, oy, 0.0], [tx, ty, 0.0])
    assert np.allclose(frame[:2, 0], bearing / np.linalg.norm(bearing))
    assert np.isclose(np.linalg.det(frame[:3, :3]), 1.0)


def test_inside_is_zero_inside_and_grows_outside() -> None:
    params = {"object_kind": "cube", "inner_half_extents": [0.1, 0.1, 0.05], "margin": 0.01}
    box = _node(0.5, -0.4, 0.625)
    assert float(constraints.inside([_node(0.52, -0.38, 0.63), box], params).abs().max()) == 0.0
    # 5 cm beyond the wall along x: the far corners stick out by 0.05 + 0.02 (half cube) - 0.09
    out = constraints.inside([_node(0.65, -0.4, 0.63), box], params)
    assert float(out.max()) == pytest.approx(0.15 + 0.02 - 0.09, abs=1e-9)


def test_inside_respects_the_container_rotation() -> None:
    params = {"object_kind": "cube", "inner_half_extents": [0.2, 0.05, 0.05], "margin": 0.0}
    # a long thin container turned by 90 degrees: 0.15 m along world y is inside, along x is not
    box = _node(0.0, 0.0, 0.0, math.pi / 2)
    assert float(constraints.inside([_node(0.0, 0.15, 0.01), box], params).max()) == 0.0
    assert float(constraints.inside([_node(0.15, 0.0, 0.01), box], params).max()) > 0.1


def test_aligned_uses_named_frames_and_height() -> None:
    params = {
        "object_frame": [0.13, 0, 0.0175, 0, 0, 0, 1],
        "target_frame": [0, 0, 0.08, 0, 0, 0, 1],
        "height": 0.05,
    }
    nail = _node(0.6, 0.1, 0.625)
    # hammer turned by 90 degrees: its head (+0.13 along its x) lies along world +y
    hammer = _node(0.6, 0.1 - 0.13, 0.625 + 0.08 + 0.05 - 0.0175, math.pi / 2)
    assert np.allclose(constraints.aligned([hammer, nail], params).numpy(), 0.0, atol=1e-9)


def test_aligned_with_an_offset_measures_the_horizontal_distance() -> None:
    """Frame points 3-4-5 cm apart in xy (and 2 cm apart in z): the residual is the distance's
    error, whatever the direction, plus the height's."""
    params = {"object_frame": [0, 0, 0, 0, 0, 0, 1], "target_frame": [0, 0, 0, 0, 0, 0, 1], "height": 0.02}
    target = _node(0.5, 0.0, 0.7)
    for angle in (0.0, 1.0, 2.5):
        obj = _node(0.5 + 0.05 * math.cos(angle), 0.05 * math.sin(angle), 0.72)
        on_circle = constraints.aligned([obj, target], {**params, "offset": 0.05}).numpy()
        assert np.allclose(on_circle, 0.0, atol=1e-6)
        inside = constraints.aligned([obj, target], {**params, "offset": 0.02}).numpy()
        assert np.allclose(inside, [[0.03, 0.0]], atol=1e-6)
    # without an offset: the xy difference itself (two components)
    obj = _node(0.53, 0.04, 0.72)
    assert np.allclose(constraints.aligned([obj, target], params).numpy(), [[0.03, 0.04, 0.0]], atol=1e-6)


def test_yaw_residual_wraps_around() -> None:
    r = constraints.yaw([_node(0, 0, 0, math.radians(179))], {"yaw": math.radians(-179)})
    assert float(r) == pytest.approx(math.radians(-2), abs=1e-9)


@given(st.floats(0.0, 1.5), st.floats(-math.pi, math.pi), st.floats(-math.pi, math.pi))
def test_upright_residual_is_the_sine_of_the_tilt(tilt: float, axis: float, yaw: float) -> None:
    """Turned about the vertical by any yaw, then tilted by ``tilt`` about a horizontal axis at
    angle ``axis``: the residual's norm is sin(tilt), pointing where the z axis leans."""
    horizontal = np.array([math.cos(axis), math.sin(axis), 0.0])
    k = np.array(
        [
            [0, -horizontal[2], horizontal[1]],
            [horizontal[2], 0, -horizontal[0]],
            [-horizontal[1], horizontal[0], 0],
        ]
    )
    tilted = np.eye(3) + math.sin(tilt) * k + (1 - math.cos(tilt)) * k @ k  # Rodrigues
    pose = np.eye(4)
    pose[:3, :3] = tilted @ pose7_to_matrix([0, 0, 0, *yaw_quat(yaw)])[:3, :3]
    node = torch.tensor(matrix_to_pose9(pose)).unsqueeze(0)
    r = constraints.upright([node], {}).numpy()[0]
    assert float(np.linalg.norm(r)) == pytest.approx(math.sin(tilt), abs=1e-9)
    assert np.allclose(r, tilted[:2, 2], atol=1e-9)


def test_fixed_transform_between_two_states() -> None:
    left1, right1 = _node(0.5, 0.1, 0.8), _node(0.5, -0.1, 0.8)
    # both grippers moved rigidly together: turned by 45 degrees about the world origin's z
    turn = pose7_to_matrix([0, 0, 0, *yaw_quat(math.pi / 4)])
    left2 = torch.tensor(matrix_to_pose9(turn @ pose9_to_matrix(left1[0].numpy()))).unsqueeze(0)
    right2 = torch.tensor(matrix_to_pose9(turn @ pose9_to_matrix(right1[0].numpy()))).unsqueeze(0)
    assert float(constraints.fixed_transform([left1, right1, left2, right2], {}).abs().max()) < 1e-9
    moved = right2.clone()
    moved[0, 0] += 0.03
    assert float(constraints.fixed_transform([left1, right1, left2, moved], {}).abs().max()) > 0.02


def test_relative_pose_compares_b_in_as_frame_with_the_given_pose() -> None:
    box = _node(0.5, 0.0, 0.6)
    turn = pose7_to_matrix([0.5, 0.0, 0.6, *yaw_quat(math.pi / 2)])
    in_box = pose7_to_matrix([0.02, -0.01, 0.03, *yaw_quat(0.3)])
    cube = torch.tensor(matrix_to_pose9(turn @ in_box)).unsqueeze(0)
    box_turned = torch.tensor(matrix_to_pose9(turn)).unsqueeze(0)
    action = torch.tensor(matrix_to_pose9(in_box)).unsqueeze(0)
    assert float(constraints.relative_pose([box_turned, cube, action], {}).abs().max()) < 1e-9
    # The same cube read in the unturned box's frame is off by the turn.
    assert float(constraints.relative_pose([box, cube, action], {}).abs().max()) > 0.5
    shifted = action.clone()
    shifted[0, 1] += 0.01  # 1 cm along the box's y
    r = constraints.relative_pose([box_turned, cube, shifted], {})
    assert float(r[0, 1]) == pytest.approx(-0.01, abs=1e-9)


def test_near_and_far_are_one_sided() -> None:
    a, b = _node(0, 0, 0), _node(0.3, 0.4, 0)  # 0.5 apart
    assert float(constraints.near([a, b], {"distance": 0.6})) == 0.0
    assert float(constraints.near([a, b], {"distance": 0.4})) == pytest.approx(0.1)
    assert float(constraints.far([a, b], {"distance": 0.4})) == 0.0
    assert float(constraints.far([a, b], {"distance": 0.7})) == pytest.approx(0.2)


@given(
    st.floats(0.0, 1.5),
    st.floats(-math.pi, math.pi),
    st.floats(-math.pi / 2, math.pi / 2),
    st.floats(0.3, 1.0),
)
def test_reach_is_the_distance_beyond_the_bound_from_the_shoulder(
    distance: float, azimuth: float, elevation: float, bound: float
) -> None:
    """A hand ``distance`` from the shoulder in any direction: zero within the bound, the excess
    beyond it; the gripper value of a robot node plays no part."""
    shoulder = np.array([0.1, -0.35, 0.958])
    direction = np.array(
        [
            math.cos(elevation) * math.cos(azimuth),
            math.cos(elevation) * math.sin(azimuth),
            math.sin(elevation),
        ]
    )
    hand = torch.cat(
        [_node(*(shoulder + distance * direction)), torch.tensor([[0.04]], dtype=torch.float64)], 1
    )
    r = constraints.reach([hand], {"shoulder": list(shoulder), "reach": bound})
    assert r.shape == (1, 1)
    assert float(r) == pytest.approx(max(0.0, distance - bound), abs=1e-9)


def test_grasps_apart_reads_the_grasp_positions_in_the_objects_frame() -> None:
    """Two grasp actions (pose9 in the object's frame) 4 cm apart along the handle, rotations
    differing: 6 cm short of a 10 cm clearance; 12 cm apart is clear."""
    giver = _node(0.03, 0.0, 0.018)
    receiver = _node(-0.01, 0.0, 0.018, math.pi)
    params = {"distance": 0.10}
    assert float(constraints.grasps_apart([giver, receiver], params)) == pytest.approx(0.06)
    assert float(constraints.grasps_apart([giver, _node(-0.09, 0.0, 0.018)], params)) == 0.0


BLOCK_HALF = [0.025, 0.025, 0.025]


def _apart(a: torch.Tensor, b: torch.Tensor, clearance: float = 0.005) -> float:
    params = {"object_half_extents": BLOCK_HALF, "target_half_extents": BLOCK_HALF, "clearance": clearance}
    r = constraints.apart([a, b], params)
    assert r.shape == (1, 1)
    return float(r)


def test_apart_is_the_shortfall_of_the_footprints_gap() -> None:
    """Two 5 cm blocks side by side: 6 cm between centres leaves 1 cm (clear of 5 mm); 5.2 cm
    leaves 2 mm, 3 mm short; turned 45 degrees, 6 cm between centres overlaps by 0.4 mm (which
    ``far`` on the centres at 5.5 cm let through)."""
    origin = _node(0.0, 0.0, 0.0)
    assert _apart(origin, _node(0.06, 0.0, 0.0)) == 0.0
    assert _apart(origin, _node(0.052, 0.0, 0.0)) == pytest.approx(0.003)
    overlap = 0.06 - 0.025 - 0.025 * math.sqrt(2)  # -0.4 mm
    assert _apart(origin, _node(0.06, 0.0, 0.0, math.pi / 4)) == pytest.approx(0.005 - overlap)


@given(
    st.floats(-0.2, 0.2),
    st.floats(-0.2, 0.2),
    st.floats(-math.pi, math.pi),
    st.floats(-math.pi, math.pi),
)
def test_apart_agrees_with_the_simulators_footprint_gap(
    x: float, y: float, yaw_a: float, yaw_b: float
) -> None:
    """The planner's residual and the goal check (gfc.sim.goals.footprint_gap) measure the same
    gap, for any placement and yaws; and the residual does not change when both blocks move
    together."""
    from gfc.sim.goals import footprint_gap

    a, b = _node(0.1, -0.3, 0.0, yaw_a), _node(0.1 + x, -0.3 + y, 0.0, yaw_b)
    gap = footprint_gap(pose9_to_matrix(a[0].numpy()), BLOCK_HALF, pose9_to_matrix(b[0].numpy()), BLOCK_HALF)
    assert _apart(a, b) == pytest.approx(max(0.0, 0.005 - gap), abs=1e-9)
    moved_a, moved_b = _node(-0.4, 0.2, 0.0, yaw_a + 1.0), _node(-0.4, 0.2, 0.0, yaw_b + 1.0)
    turn = np.array([[math.cos(1.0), -math.sin(1.0)], [math.sin(1.0), math.cos(1.0)]])
    moved_b[0, :2] += torch.tensor(turn @ np.array([x, y]))
    assert _apart(moved_a, moved_b) == pytest.approx(_apart(a, b), abs=1e-9)


def test_released_clear_wants_a_placement_beside_the_rack_or_on_its_top() -> None:
    """A 5 cm block placed 13 cm in front of the rack's centre (its bar 10 cm wide, 12 cm high)
    is clear; 6 cm in front it would be released 1.5 cm into the bar's footprint (plus the 6 mm
    clearance); a hook laid on the bar's top is clear, 2 cm lower it is not."""
    rack = [0.05, 0.25, 0.06]
    params = {"clearance": 0.006, "object_half_extents": BLOCK_HALF, "target_half_extents": rack}

    def residual(x: float, z: float, half: list[float] = BLOCK_HALF) -> float:
        return float(constraints.released_clear([_node(x, 0.0, z)], {**params, "object_half_extents": half}))

    assert residual(-0.13, 0.003) == 0.0
    assert residual(-0.06, 0.003) == pytest.approx(0.015 + 0.006)
    hook = [0.2, 0.06, 0.015]
    assert residual(0.0, 0.123, hook) == 0.0
    assert residual(0.0, 0.103, hook) == pytest.approx(0.017)


def test_placed_reach_carries_the_place_action_into_the_world_by_the_target() -> None:
    """A release 0.1 m along the target's x, the target turned 90 degrees at (0.5, 0, 0): the
    point is (0.5, 0.1, 0), 0.51 m from a shoulder at the origin: 0.06 beyond a 0.45 m reach."""
    target = _node(0.5, 0.0, 0.0, math.pi / 2)
    action = _node(0.1, 0.0, 0.0)
    r = constraints.placed_reach([target, action], {"shoulder": [0.0, 0.0, 0.0], "reach": 0.45})
    assert float(r) == pytest.approx(math.hypot(0.5, 0.1) - 0.45)


def _grasp_tilted(pitch: float) -> torch.Tensor:
    """A grasp pose9 at the source's rim whose approach (z axis) is turned by ``pitch`` about
    the y axis: +pi/2 points along +x, -pi/2 along -x, pi straight down."""
    c, s = math.cos(pitch), math.sin(pitch)
    mat = np.eye(4)
    mat[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
    mat[:3, 3] = [0.0, 0.0, 0.08]
    return torch.tensor(matrix_to_pose9(mat), dtype=torch.float64).unsqueeze(0)


RIMS = {"source_frame": [0.0, 0.0, 0.1, 0, 0, 0, 1], "target_frame": [0.0, 0.0, 0.08, 0, 0, 0, 1]}


@pytest.mark.parametrize(
    ("pitch", "expected"),
    [(math.pi / 2, 0.0), (-math.pi / 2, 1.0), (math.pi, 0.0), (-math.pi / 4, math.sqrt(0.5))],
)
def test_palm_clear_is_the_approach_against_the_pour(pitch: float, expected: float) -> None:
    """Source at the origin, target 0.2 m along +x (the pour's direction): a hand approaching
    along +x (behind the source) or from above is clear; one approaching along -x has its palm
    between the two (residual 1, the whole approach against the pour); tilted 45 degrees, the
    horizontal part's share."""
    r = constraints.palm_clear([_node(0, 0, 0), _node(0.2, 0, 0), _grasp_tilted(pitch)], RIMS)
    assert float(r) == pytest.approx(expected, abs=1e-9)


@given(st.floats(-math.pi, math.pi), st.floats(-math.pi, math.pi))
def test_palm_clear_turns_with_the_scene(scene_yaw: float, pitch: float) -> None:
    """Turning source and target together about the vertical (the grasp is in the source's
    frame, so it turns with it) leaves the residual as it was."""
    c, s = math.cos(scene_yaw), math.sin(scene_yaw)
    grasp = _grasp_tilted(pitch)
    still = constraints.palm_clear([_node(0, 0, 0), _node(0.2, 0, 0), grasp], RIMS)
    turned = constraints.palm_clear([_node(0, 0, 0, scene_yaw), _node(0.2 * c, 0.2 * s, 0), grasp], RIMS)
    assert float(turned) == pytest.approx(float(still), abs=1e-9)
    assert float(still) == pytest.approx(max(0.0, -math.sin(pitch)), abs=1e-9)


# A pull by an arm whose base is at the origin, of a 4 cm block on the x axis; the hook's tip
# frame 10 cm across its x axis, its bar 1 cm half-wide.
_PULL_PARAMS: dict[str, object] = {
    "sign": -1.0,
    "base": [0.0, 0.0, 0.0],
    "tip": [0.0, 0.1, 0.0],
    "bar_half_x": 0.01,
    "half_extents": [0.02, 0.02, 0.02],
    "lateral": [0.0, 0.2],
}
_PULL_ALONG_THE_LINE = torch.tensor([[0.03, 0.04, 0.1, 0.0]], dtype=torch.float64)  # x, y, r, theta


def test_stroke_margins_weigh_by_their_gain_and_a_pull_clears_the_shaft() -> None:
    """A pull of a 4 cm block straight towards the base (at the origin): the hook's bar (1 cm
    half-width) touches the block's far side (gap 0) and the block's centre is 6 cm across the
    face. With a 1 cm clearance wanted, the short residual is the gain times 1 cm; with the
    shaft's edge at 5 cm, the block's near side (2 cm from its centre) needs 7 cm across, so it is
    1 cm outside the face, again times the gain. Sliding is unweighted."""
    block, after = _node(0.5, 0.0, 0.02), _node(0.4, 0.0, 0.02)
    action = _PULL_ALONG_THE_LINE
    params = {**_PULL_PARAMS, "clearance": 0.01}
    plain = constraints.stroke([block, after, action], params).numpy()[0]
    np.testing.assert_allclose(plain, [0.0, 0.0, 0.0, 0.01], atol=1e-9)
    weighed = constraints.stroke([block, after, action], {**params, "margin_gain": 4.0, "shaft_edge": 0.05})
    np.testing.assert_allclose(weighed.numpy()[0], [0.0, 0.0, 0.04, 0.04], atol=1e-9)
    # A 6 x 4 cm block turned a quarter: its near side is 3 cm from its centre, 2 cm outside.
    turned = _node(0.5, 0.0, 0.02, math.pi / 2)
    wide = constraints.stroke(
        [turned, after, action], {**params, "half_extents": [0.03, 0.02, 0.02], "shaft_edge": 0.05}
    )
    assert float(wide[0, 2]) == pytest.approx(0.02, abs=1e-9)


@pytest.mark.parametrize(
    ("block_yaw_deg", "excess_deg"),
    [(0.0, 0.0), (20.0, 0.0), (-30.0, 0.0), (40.0, 10.0), (-42.0, 12.0), (80.0, 0.0), (130.0, 10.0)],
)
def test_a_stroke_meeting_its_block_askew_pays_the_excess_turn(
    block_yaw_deg: float, excess_deg: float
) -> None:
    """The tool points along the base-to-block line (theta 0, the block on the x axis), so the
    block's face is turned from the hook's by its yaw, a quarter turn being the same box: past
    30 degrees the excess (rad) times the block's 2 cm half side, times the margin gain."""
    block = _node(0.5, 0.0, 0.02, math.radians(block_yaw_deg))
    params = {**_PULL_PARAMS, "margin_gain": 4.0, "max_turn": math.radians(30.0)}
    out = constraints.stroke([block, block, _PULL_ALONG_THE_LINE], params)
    assert out.shape == (1, 5)
    assert float(out[0, 4]) == pytest.approx(4.0 * math.radians(excess_deg) * 0.02, abs=1e-9)
