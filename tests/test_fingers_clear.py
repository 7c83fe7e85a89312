"""The ``fingers_clear`` factor: the fingers placing a block keep clear of the neighbours placed
before it and of the walls. Analytic cases (the 16 mm the screen's mirror measured on the Panda's
fingers for the same scene) and invariances."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from gfc.constraints import _finger_gap, _fingers, _pose_of, fingers_clear
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
