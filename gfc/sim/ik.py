"""Inverse kinematics on the planning mirror, with restarts and a forward-kinematics check."""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb

from gfc.geometry import FloatArray, matrix_to_quat
from gfc.sim.panda import (
    ARM_DOF,
    EE_LINK,
    FINGER_MAX,
    LOWER_LIMITS,
    UPPER_LIMITS,
    ee_matrix,
    set_joints,
    within_limits,
    wrap_to_limits,
)
from gfc.sim.world import World

POSITION_TOLERANCE = 0.004  # m
ANGLE_TOLERANCE = math.radians(3.0)
# PyBullet's IK honours limits and rest poses only when the lists cover the fingers too.
_LOWER = [*LOWER_LIMITS, 0.0, 0.0]
_UPPER = [*UPPER_LIMITS, FINGER_MAX, FINGER_MAX]
_RANGES = [u - lo for u, lo in zip(_UPPER, _LOWER, strict=True)]


def pose_error(a: FloatArray, b: FloatArray) -> tuple[float, float]:
    """Position (m) and rotation angle (rad) between two 4x4 transforms."""
    position = float(np.linalg.norm(a[:3, 3] - b[:3, 3]))
    cos = (np.trace(a[:3, :3].T @ b[:3, :3]) - 1.0) / 2.0
    return position, float(math.acos(max(-1.0, min(1.0, cos))))


def solve_ik(
    world: World,
    robot: str,
    world_from_ee: FloatArray,
    seed_joints: FloatArray,
    rng: np.random.Generator,
    restarts: int = 12,
) -> FloatArray | None:
    """Joint angles that put the end effector of ``robot`` at ``world_from_ee``, or ``None``.

    The first attempt starts from ``seed_joints`` (so consecutive waypoints stay on one branch);
    the others from random configurations. Answers are checked by forward kinematics.
    """
    client = world.mirror.client
    panda = world.mirror.robots[robot]
    position = list(world_from_ee[:3, 3])
    quat = list(matrix_to_quat(world_from_ee[:3, :3]))
    for attempt in range(restarts + 1):
        start = seed_joints if attempt == 0 else rng.uniform(LOWER_LIMITS, UPPER_LIMITS)
        q = np.asarray(start, dtype=np.float64)
        for _ in range(4):  # PyBullet's damped least squares converges in a few rounds
            set_joints(client, panda, q, FINGER_MAX)
            solution = pb.calculateInverseKinematics(
                panda.body,
                EE_LINK,
                position,
                quat,
                lowerLimits=_LOWER,
                upperLimits=_UPPER,
                jointRanges=_RANGES,
                restPoses=[*start, 0.0, 0.0],  # the null space pulls towards the start
                maxNumIterations=100,
                residualThreshold=1e-6,
                physicsClientId=client,
            )
            q = wrap_to_limits(np.asarray(solution[:ARM_DOF]))
            set_joints(client, panda, q, FINGER_MAX)
            dp, da = pose_error(ee_matrix(client, panda), world_from_ee)
            if dp < POSITION_TOLERANCE and da < ANGLE_TOLERANCE and within_limits(q):
                return q
    return None
