"""What a benchmark task provides: a seeded scene sampler that returns the full plan request
(scene, skeleton with groups, goal) and hand-written reference actions for that scene."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from gfc.geometry import (
    FloatArray,
    invert,
    matrix_to_pose9,
    matrix_to_quat,
    pose7_to_matrix,
    yaw_quat,
)
from gfc.plan.schema import PlanRequest

TABLE_Z = 0.625
LEFT_BASE = (0.0, 0.35, TABLE_Z)
RIGHT_BASE = (0.0, -0.35, TABLE_Z)
# Gripper pointing down (world -z), fingers closing along the object's y axis.
DOWN = np.diag([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class TaskInstance:
    """One sampled scene of a task with the reference parameters that solve it."""

    task: str
    seed: int
    plan: PlanRequest
    reference_actions: list[FloatArray | None]
    contents: dict[str, int] = field(default_factory=dict)  # container -> beads


Sampler = Callable[[int], TaskInstance]


def robots_json() -> list[dict[str, object]]:
    return [
        {"name": "left", "base": list(LEFT_BASE)},
        {"name": "right", "base": list(RIGHT_BASE)},
    ]


def pose7(x: float, y: float, z: float, yaw: float = 0.0) -> list[float]:
    return [x, y, z, *(float(v) for v in yaw_quat(yaw))]


def frame(position: Sequence[float], rotation: FloatArray) -> FloatArray:
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = position
    return out


def rot_z(angle: float) -> FloatArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def grasp9(position: Sequence[float], rotation: FloatArray = DOWN) -> FloatArray:
    """A grasp (or placement) pose as the 9-vector actions use."""
    return matrix_to_pose9(frame(position, rotation))


def in_base(base: Sequence[float], world_from_ee: FloatArray) -> FloatArray:
    """A world pose -> the same pose in the robot's base frame (a move's action: where the held
    object, or the empty hand, goes)."""
    world_from_base = pose7_to_matrix([*base, 0.0, 0.0, 0.0, 1.0])
    return matrix_to_pose9(invert(world_from_base) @ world_from_ee)


def world_pose(pose: Sequence[float]) -> FloatArray:
    return pose7_to_matrix(pose)


def quat_of(rotation: FloatArray) -> list[float]:
    return [float(v) for v in matrix_to_quat(rotation)]
