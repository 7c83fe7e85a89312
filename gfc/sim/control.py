"""Execution under physics: joint trajectories, straight-line end-effector motions, grasps.

Robots move only by joint motors; objects move only by contact or by a grasp the fingers made.
Two arms acting at once get their joint targets set in the same physics steps.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import pybullet as pb

from gfc.geometry import FloatArray, invert, matrix_to_quat, pose7_to_matrix
from gfc.sim.collision import CollisionFn
from gfc.sim.ik import solve_ik
from gfc.sim.panda import (
    EE_LINK,
    FINGER_JOINTS,
    FINGER_MAX,
    arm_joints,
    command_fingers,
    ee_matrix,
    hold_position,
)
from gfc.sim.world import Grasp, World, object_matrix, step

MAX_JOINT_SPEED = 1.0  # rad/s of the fastest joint along a path
SETTLE_LIMIT = 240  # steps to let the arm converge on the last waypoint
CONVERGED = 0.01  # rad
CARTESIAN_STEP = 0.01  # m between IK waypoints of a straight-line motion
GRASP_FORCE = 400.0  # N: the fixed constraint's strength, ~ a Panda's payload with margin


def _resample(path: list[FloatArray], steps: int) -> list[FloatArray]:
    """``steps`` points evenly spaced in time along a piecewise-linear joint path."""
    lengths = [float(np.max(np.abs(b - a))) for a, b in itertools.pairwise(path)]
    total = sum(lengths)
    if total == 0.0:
        return [path[-1]] * steps
    cumulative = np.concatenate([[0.0], np.cumsum(lengths)])
    out = []
    for s in np.linspace(0.0, total, steps):
        k = min(int(np.searchsorted(cumulative, s, side="right")) - 1, len(lengths) - 1)
        t = 0.0 if lengths[k] == 0 else (s - cumulative[k]) / lengths[k]
        out.append(path[k] + t * (path[k + 1] - path[k]))
    return out


def path_steps(path: list[FloatArray], speed: float = MAX_JOINT_SPEED) -> int:
    length = sum(float(np.max(np.abs(b - a))) for a, b in itertools.pairwise(path))
    return max(2, math.ceil(length / speed * 240.0))


def execute_paths(
    world: World,
    paths: dict[str, list[FloatArray]],
    fingers: dict[str, float],
    speed: float = MAX_JOINT_SPEED,
) -> None:
    """Drive every robot along its joint path, all in the same physics steps, then settle."""
    steps = max(path_steps(p, speed) for p in paths.values())
    timed = {r: _resample(p, steps) for r, p in paths.items()}
    robots = world.physics.robots
    for k in range(steps):
        for r, waypoints in timed.items():
            hold_position(world.client, robots[r], waypoints[k], fingers[r])
        step(world)
    for _ in range(SETTLE_LIMIT):
        done = all(
            np.max(np.abs(arm_joints(world.client, robots[r]) - p[-1])) < CONVERGED for r, p in paths.items()
        )
        if done:
            break
        step(world)


def _slerp(q0: FloatArray, q1: FloatArray, t: float) -> FloatArray:
    dot = float(np.dot(q0, q1))
    if dot < 0.0:
        q1, dot = -q1, -dot
    if dot > 0.9995:
        q = q0 + t * (q1 - q0)
        return np.asarray(q / np.linalg.norm(q))
    theta = math.acos(dot)
    return np.asarray((math.sin((1 - t) * theta) * q0 + math.sin(t * theta) * q1) / math.sin(theta))


def interpolate_poses(a: FloatArray, b: FloatArray, count: int) -> list[FloatArray]:
    """``count`` poses from ``a`` to ``b`` (both 4x4), straight in position, slerp in rotation."""
    qa, qb = matrix_to_quat(a[:3, :3]), matrix_to_quat(b[:3, :3])
    out = []
    for t in np.linspace(0.0, 1.0, count):
        p = a[:3, 3] + t * (b[:3, 3] - a[:3, 3])
        out.append(pose7_to_matrix([*p, *_slerp(qa, qb, float(t))]))
    return out


def waypoint_count(a: FloatArray, b: FloatArray) -> int:
    distance = float(np.linalg.norm(b[:3, 3] - a[:3, 3]))
    cos = (np.trace(a[:3, :3].T @ b[:3, :3]) - 1.0) / 2.0
    angle = math.acos(max(-1.0, min(1.0, cos)))
    return max(2, math.ceil(max(distance / CARTESIAN_STEP, angle / math.radians(3.0))) + 1)


def cartesian_joint_path(
    world: World,
    robot: str,
    start_joints: FloatArray,
    poses: list[FloatArray],
    rng: np.random.Generator,
) -> list[FloatArray] | None:
    """Joint waypoints tracking end-effector ``poses`` on one IK branch, or ``None``."""
    path = [start_joints]
    for pose in poses[1:]:
        q = solve_ik(world, robot, pose, path[-1], rng, restarts=0)
        if q is None or np.max(np.abs(q - path[-1])) > 0.35:
            return None
        path.append(q)
    return path


def tracks_lines(
    world: World,
    robot: str,
    q: FloatArray,
    poses: Sequence[FloatArray],
    rng: np.random.Generator,
    guard: CollisionFn | None = None,
) -> bool:
    """Whether straight end-effector lines through ``poses`` (the first is where ``q`` puts the
    hand) can be tracked from joint configuration ``q`` on one IK branch; with ``guard``, every
    joint waypoint on the way must pass it too."""
    joints_now = q
    for a, b in itertools.pairwise(poses):
        path = cartesian_joint_path(
            world, robot, joints_now, interpolate_poses(a, b, waypoint_count(a, b)), rng
        )
        if path is None or (guard is not None and any(guard(p) is not None for p in path[1:])):
            return False
        joints_now = path[-1]
    return True


def fingers_touching(world: World, robot: str, object_body: int) -> bool:
    client = world.client
    body = world.physics.robots[robot].body
    return all(
        len(pb.getContactPoints(bodyA=body, bodyB=object_body, linkIndexA=finger, physicsClientId=client)) > 0
        for finger in FINGER_JOINTS
    )


def close_grippers(world: World, pairs: list[tuple[str, str]], max_steps: int = 240) -> list[Grasp | None]:
    """Close the fingers of several robots in the same physics steps (``(robot, object)`` pairs).

    Each grasp is contact-gated: a robot's fixed constraint is made only once both of its
    fingers touch its object; a robot whose fingers close without that gets ``None``.
    """
    for robot, _ in pairs:
        command_fingers(world.client, world.physics.robots[robot], 0.0)
    pending = {robot for robot, _ in pairs}
    for _ in range(max_steps):
        step(world)
        pending = {
            r
            for r, o in pairs
            if r in pending and not fingers_touching(world, r, world.physics.objects[o].body)
        }
        if not pending:
            break
    step(world, 24)  # let the pads press
    return [
        _fix_to_hand(world, robot, obj)
        if fingers_touching(world, robot, world.physics.objects[obj].body)
        else None
        for robot, obj in pairs
    ]


def close_gripper(world: World, robot: str, object_name: str) -> Grasp | None:
    return close_grippers(world, [(robot, object_name)])[0]


def _fix_to_hand(world: World, robot: str, object_name: str) -> Grasp:
    panda = world.physics.robots[robot]
    obj = world.physics.objects[object_name]
    world_from_ee = ee_matrix(world.client, panda)
    ee_from_object = invert(world_from_ee) @ object_matrix(world.physics, object_name)
    ee_from_com = ee_from_object @ obj.object_from_com
    constraint = pb.createConstraint(
        panda.body,
        EE_LINK,
        obj.body,
        -1,
        pb.JOINT_FIXED,
        [0.0, 0.0, 0.0],
        parentFramePosition=list(ee_from_com[:3, 3]),
        childFramePosition=[0.0, 0.0, 0.0],
        parentFrameOrientation=list(matrix_to_quat(ee_from_com[:3, :3])),
        physicsClientId=world.client,
    )
    pb.changeConstraint(constraint, maxForce=GRASP_FORCE, physicsClientId=world.client)
    grasp = Grasp(object_name, constraint, ee_from_object)
    world.grasps[robot] = grasp
    return grasp


def open_gripper(world: World, robot: str, steps: int = 60, finger: float = FINGER_MAX) -> None:
    """Let go: remove the grasp constraint and open the fingers (each to ``finger`` m)."""
    grasp = world.grasps.pop(robot, None)
    if grasp is not None:
        pb.removeConstraint(grasp.constraint, physicsClientId=world.client)
    command_fingers(world.client, world.physics.robots[robot], finger)
    step(world, steps)


def holding(world: World, robot: str) -> str | None:
    grasp = world.grasps.get(robot)
    return None if grasp is None else grasp.object


def gripper_target(world: World, robot: str) -> float:
    """The finger command that keeps the current grip: closed when holding, open otherwise."""
    return 0.0 if robot in world.grasps else FINGER_MAX
