"""Equivalent poses of symmetric objects: what the executor falls back to when the commanded
grasp or placement cannot be reached (gfc.sim.skills.motions.symmetries)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from gfc.geometry import pose9_to_matrix
from gfc.plan.schema import PlanRequest, Scene
from gfc.sim.bodies import TABLE_TOP_Z
from gfc.sim.execute import execute_plan
from gfc.sim.skills.motions import symmetries, upright_first
from gfc.sim.world import build_world
from gfc.tasks.base import frame, grasp9, robots_json
from gfc.tasks.single_arm import BLOCK_GRASP_Z

HALF = 0.025  # the block's half size


def _scene(block_pose: list[float]) -> Scene:
    return Scene.model_validate(
        {
            "robots": robots_json(),
            "objects": [
                {"name": "block", "kind": "block", "pose": block_pose},
                {"name": "hammer", "kind": "hammer", "pose": [0.4, 0.3, TABLE_TOP_Z, 0, 0, 0, 1]},
            ],
        }
    )


def test_a_block_has_the_24_rotations_of_a_cube_about_its_centre_and_a_hammer_none() -> None:
    corners = np.array(
        [[x, y, z] for x, y, z in itertools.product((-HALF, HALF), (-HALF, HALF), (0.0, 2 * HALF))]
    )
    with build_world(_scene([0.5, -0.35, TABLE_TOP_Z, 0, 0, 0, 1])) as world:
        motions = symmetries(world, "block")
        assert len(motions) == 24
        np.testing.assert_array_equal(motions[0], np.eye(4))
        rotations = {tuple(np.round(m[:3, :3]).astype(int).ravel()) for m in motions}
        assert len(rotations) == 24
        for motion in motions:
            moved = corners @ motion[:3, :3].T + motion[:3, 3]
            # every corner lands on a corner: the block's box maps onto itself
            distance = np.linalg.norm(moved[:, None, :] - corners[None, :, :], axis=-1).min(axis=1)
            assert distance.max() < 1e-12
        assert len(symmetries(world, "hammer")) == 1


def test_upright_first_keeps_the_commanded_pose_first_then_the_steepest_hands() -> None:
    def hand(tilt_deg: float) -> np.ndarray:
        t = math.radians(tilt_deg)
        rotation = np.array(
            [[1.0, 0.0, 0.0], [0.0, -math.cos(t), math.sin(t)], [0.0, -math.sin(t), -math.cos(t)]]
        )
        return frame([0.0, 0.0, 0.0], rotation)  # z axis tilted tilt_deg from straight down

    commanded, steep, level, tilted, upward = hand(90.0), hand(5.0), hand(90.0), hand(25.0), hand(180.0)
    ordered = upright_first([commanded, level, tilted, upward, steep])
    assert [round(math.degrees(math.acos(-p[2, 2]))) for p in ordered] == [90, 5, 25]
    assert len(upright_first([commanded, *[hand(0.0)] * 6], limit=4)) == 4


@pytest.mark.slow
def test_a_block_lying_on_its_side_is_picked_from_above() -> None:
    """The block lies on a side face (its z axis along world +x); the commanded grasp, from
    above in the block's frame, is a horizontal grasp from beyond it. The executor falls back to
    the same grasp of the same cube seen upright, from above, and picks it."""
    lying = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # z -> +x
    centre = np.array([0.55, -0.35, TABLE_TOP_Z + HALF])
    origin = centre - lying @ np.array([0.0, 0.0, HALF])
    from gfc.geometry import matrix_to_quat

    pose = [*origin, *matrix_to_quat(lying)]
    plan = PlanRequest.model_validate(
        {
            "scene": _scene([float(v) for v in pose]).model_dump(),
            "skeleton": [{"skill": "pick", "robot": "right", "object": "block"}],
        }
    )
    action = grasp9([0.0, 0.0, BLOCK_GRASP_Z])
    commanded = frame(origin, lying) @ pose9_to_matrix(action)
    assert abs(commanded[2, 2]) < 1e-9, "the commanded grasp is horizontal"
    outcome = execute_plan(plan, [action], seed=0)
    assert outcome.success, outcome.steps[-1].reason
    assert "lifted" in outcome.steps[0].reason
