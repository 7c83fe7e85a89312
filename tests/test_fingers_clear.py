"""The ``fingers_clear`` factor: the fingers placing a block keep clear of the neighbours placed
before it and of the walls. Analytic cases (the 16 mm the screen's mirror measured on the Panda's
fingers for the same scene) and invariances. Also ``grasp_centred``: a block held near the middle of
the pads."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from gfc.constraints import _finger_gap, _fingers, _pose_of, fingers_clear, grasp_centred
from gfc.kinds import FINGER_THICKNESS, FINGER_WIDTH
from gfc.plan.compiler import FINGER_CLEARANCE

HALF = 0.025  # a 5 cm block
PARAMS = {
    "clearance": FINGER_CLEARANCE,
    "finger_thickness": FINGER_THICKNESS,
    "finger_width": FINGER_WIDTH,
    "object_half_extents": [HALF] * 3,
    "neighbour_half_extents": [[HALF] * 3],
    "inner_half_extents": None,
}


def _pose9(x: float, y: float, yaw_deg: float, z: float = 0.0, down: bool = False) -> torch.Tensor:
    """A pose9 (1, 9): position, then the x and y axes; ``down``: a hand pointing down (y and z
    flipped, as the tasks' top-down grasps)."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    flip = -1.0 if down else 1.0
    return torch.tensor([[x, y, z, c, s, 0.0, -s * flip, c * flip, 0.0]], dtype=torch.float64)


def _approx(value: float) -> object:
    return pytest.approx(value, abs=1e-9)


def _gap(grasp_yaw: float, neighbour: torch.Tensor) -> float:
    placed = _pose9(0.0, 0.0, 0.0)
    hand = _pose_of(placed) @ _pose_of(_pose9(0.0, 0.0, grasp_yaw, z=0.031, down=True))
    return float(_finger_gap(_fingers(placed, hand, PARAMS), [neighbour], PARAMS))


def test_fingers_closing_towards_a_neighbour_9mm_away_reach_16mm_into_it() -> None:
    """A top-down hand closes along its y axis: on a block at the origin its fingers stand from
    2.5 cm (the face) to 2.5 + FINGER_THICKNESS cm along y. A neighbour 9 mm beyond the face (its
    near face at 3.4 cm): 1.6 cm of overlap, what the screen measures on the Panda's fingers.
    Across (the neighbour along x): clear by 3.4 - FINGER_WIDTH / 2 cm."""
    beyond_y = _pose9(0.0, 2 * HALF + 0.009, 0.0)
    beyond_x = _pose9(2 * HALF + 0.009, 0.0, 0.0)
    assert _gap(0.0, beyond_y) == _approx(HALF + 0.009 - (HALF + FINGER_THICKNESS))
    assert _gap(0.0, beyond_x) == _approx(HALF + 0.009 - FINGER_WIDTH / 2)
    # The factor: a quarter turn of the hand closes along x, clear of the neighbour along y.
    grasp = _pose9(0.0, 0.0, 0.0, z=0.031, down=True)
    assert float(fingers_clear([_pose9(0.0, 0.0, 0.0), grasp, beyond_y], PARAMS)) == 0.0


def test_a_grasp_45_degrees_off_the_faces_leaves_no_turn_clear() -> None:
    """At 45 degrees the fingers close on the block's corners, HALF * sqrt 2 from its centre
    along u = (1, 1) / sqrt 2, whichever quarter turn; a neighbour 9 mm beyond the +y face is
    separated from the +u finger best along the finger's across axis v = (-1, 1) / sqrt 2, and
    there they overlap by 8 mm."""
    root = math.sqrt(0.5)
    reach = HALF * 2 * root + FINGER_THICKNESS / 2  # finger centre from the block's centre, on u
    finger = np.array([reach * root, reach * root])  # the finger on the +u side
    neighbour_xy = np.array([0.0, 2 * HALF + 0.009])
    v = np.array([-root, root])
    # On v the finger's radius is half its width, the neighbour's HALF * (|v_x| + |v_y|).
    along_v = abs(float((neighbour_xy - finger) @ v)) - FINGER_WIDTH / 2 - HALF * 2 * root
    grasp = _pose9(0.0, 0.0, 45.0, z=0.031, down=True)
    neighbour = _pose9(float(neighbour_xy[0]), float(neighbour_xy[1]), 0.0)
    residual = float(fingers_clear([_pose9(0.0, 0.0, 0.0), grasp, neighbour], PARAMS))
    assert residual == _approx(FINGER_CLEARANCE - along_v)
    assert residual > FINGER_CLEARANCE  # the fingers overlap it


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-0.1, 0.1),
    y=st.floats(-0.1, 0.1),
    yaw=st.floats(-180.0, 180.0),
    grasp_yaw=st.floats(-180.0, 180.0),
    scene_turn=st.floats(-180.0, 180.0),
)
def test_the_factor_turns_with_the_scene_and_ignores_a_half_turn_of_the_hand(
    x: float, y: float, yaw: float, grasp_yaw: float, scene_turn: float
) -> None:
    """The residual depends on where things are relative to each other: turning the block and
    its neighbour together about the target's origin changes nothing, nor does turning the hand
    a half turn (the two fingers swap)."""
    nx, ny = 0.07, 0.01

    def residual(turn: float, hand_yaw: float) -> float:
        c, s = math.cos(math.radians(turn)), math.sin(math.radians(turn))
        placed = _pose9(c * x - s * y, s * x + c * y, yaw + turn)
        neighbour = _pose9(c * nx - s * ny, s * nx + c * ny, 30.0 + turn)
        grasp = _pose9(0.003, -0.002, hand_yaw, z=0.031, down=True)
        return float(fingers_clear([placed, grasp, neighbour], PARAMS))

    base = residual(0.0, grasp_yaw)
    assert residual(scene_turn, grasp_yaw) == _approx(base)
    assert residual(0.0, grasp_yaw + 180.0) == _approx(base)


def test_the_walls_count_and_one_turn_must_clear_every_neighbour_and_wall() -> None:
    """A block 2 cm from a wall along y and a neighbour 9 mm beyond it along x: the hand closing
    along y puts a finger 5 mm into the wall, the one closing along x a finger 16 mm into the
    neighbour; no turn is clear, and the residual is the better turn's shortfall (the wall's)."""
    inner = [0.14, 0.09, 0.04]
    params = {**PARAMS, "inner_half_extents": inner}
    y = inner[1] - HALF - 0.02  # the block's face 2 cm from the +y wall
    placed = _pose9(0.0, y, 0.0)
    neighbour = _pose9(2 * HALF + 0.009, y, 0.0)
    grasp = _pose9(0.0, 0.0, 0.0, z=0.031, down=True)
    into_wall = FINGER_THICKNESS - 0.02
    assert float(fingers_clear([placed, grasp, neighbour], params)) == _approx(FINGER_CLEARANCE + into_wall)
    # Without the neighbour the hand closes along x, clear of the walls by 14 - 2.5 - 2.5 cm.
    alone = {**params, "neighbour_half_extents": []}
    assert float(fingers_clear([placed, grasp], alone)) == 0.0


def _gap_pair_by_pair(
    fingers: list[torch.Tensor], others: list[torch.Tensor], params: dict[str, object]
) -> torch.Tensor:
    """The finger gap one finger, neighbour and corner at a time (what ``_finger_gap`` batches)."""
    from gfc.constraints import footprint_separation

    half = (FINGER_THICKNESS / 2, FINGER_WIDTH / 2)
    halves = params["neighbour_half_extents"]
    assert isinstance(halves, list)
    gaps = [footprint_separation(f, o, half, h) for f in fingers for o, h in zip(others, halves, strict=True)]
    inner = params["inner_half_extents"]
    assert isinstance(inner, list)
    walls = torch.tensor(inner[:2], dtype=torch.float64)
    for f in fingers:
        pose = _pose_of(f)
        for sx in (1.0, -1.0):
            for sy in (1.0, -1.0):
                corner = pose[..., :2, 3] + sx * half[0] * pose[..., :2, 0] + sy * half[1] * pose[..., :2, 1]
                gaps.append((walls - corner.abs()).min(dim=-1, keepdim=True).values)
    return torch.stack(gaps).min(dim=0).values


@settings(max_examples=40, deadline=None)
@given(
    poses=st.lists(
        st.tuples(st.floats(-0.12, 0.12), st.floats(-0.08, 0.08), st.floats(-180.0, 180.0)),
        min_size=2,
        max_size=5,
    ),
    grasp_yaw=st.floats(-180.0, 180.0),
)
def test_the_batched_gap_equals_the_gap_taken_pair_by_pair(
    poses: list[tuple[float, float, float]], grasp_yaw: float
) -> None:
    """Neighbours of two sizes (blocks and 4 cm cubes) and the box's walls; a batch of three
    scenes (the neighbours shifted and the grasp turned row by row)."""

    def rows(x: float, y: float, yaw: float, step: float) -> torch.Tensor:
        return torch.cat([_pose9(x + k * step, y - k * step, yaw + 25.0 * k) for k in range(3)])

    placed = rows(*poses[0], 0.0)
    others = [rows(*p, 0.01) for p in poses[1:]]
    params = {
        **PARAMS,
        "neighbour_half_extents": [[HALF] * 3 if k % 2 else [0.02] * 3 for k in range(len(others))],
        "inner_half_extents": [0.14, 0.09, 0.04],
    }
    grasps = torch.cat([_pose9(0.002, -0.001, grasp_yaw + 40.0 * k, z=0.031, down=True) for k in range(3)])
    hand = _pose_of(placed) @ _pose_of(grasps)
    fingers = _fingers(placed, hand, params)
    batched = _finger_gap(fingers, others, params)
    assert batched.shape == (3, 1)
    assert torch.allclose(batched, _gap_pair_by_pair(fingers, others, params), atol=1e-12)


@pytest.mark.parametrize(
    ("lateral", "along_closing", "yaw_deg", "expected"),
    [
        (0.0, 0.0, 0.0, 0.0),  # centred
        (0.008, 0.02, 0.0, 0.0),  # within the band; off centre along the closing axis is free
        (0.02, 0.0, 0.0, 0.01),  # 1 cm beyond the 1 cm band
        (-0.025, 0.0, 30.0, 0.015),  # the hand turned: the offset is measured along its pads
    ],
)
def test_grasp_centred_measures_the_offset_along_the_pads(
    lateral: float, along_closing: float, yaw_deg: float, expected: float
) -> None:
    """The grasp point's offset across the fingers' closing axis (the hand's y), less the band."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    across, closing = np.array([c, s]), np.array([-s, c])  # the hand's x and y on the table
    point = lateral * across + along_closing * closing
    grasp = _pose9(float(point[0]), float(point[1]), yaw_deg, z=0.03, down=True)
    assert float(grasp_centred([grasp], {"band": 0.01})) == _approx(expected)
