"""The Franka Panda: loading, joint layout, forward kinematics and joint control.

Joints 0-6 move the arm, 9-10 are the fingers (0-0.04 m each), link 11 (``panda_grasptarget``)
is the end effector: the point between the finger pads. Everything takes the physics client.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as pb
import pybullet_data

from gfc.geometry import FloatArray, pose7_to_matrix, yaw_quat

ARM_JOINTS = (0, 1, 2, 3, 4, 5, 6)
FINGER_JOINTS = (9, 10)
HAND_LINKS = (8, 9, 10, 11)  # hand, fingers, grasp target: these may touch what they hold
EE_LINK = 11
ARM_DOF = len(ARM_JOINTS)
FINGER_MAX = 0.04
# Pointing down, fingers along the base y axis; the end effector 0.31 m in front of the base and
# 0.49 m above it: clear of the table and of everything on it, reachable from both sides.
HOME_JOINTS: tuple[float, ...] = (0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785)
LOWER_LIMITS = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
UPPER_LIMITS = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
ARM_FORCES = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
FINGER_FORCE = 40.0
FINGER_GEAR_FORCE = 20.0  # N: half a finger's drive: centres a free object, yields to a held one
# Stiff joint servos: dense waypoints are tracked within a few millimetres at the end effector.
POSITION_GAIN = 1.0


@dataclass(frozen=True)
class Panda:
    name: str
    body: int
    world_from_base: FloatArray  # 4x4


def load_panda(client: int, name: str, base: list[float], yaw: float) -> Panda:
    world_from_base = pose7_to_matrix([*base, *yaw_quat(yaw)])
    body = pb.loadURDF(
        f"{pybullet_data.getDataPath()}/franka_panda/panda.urdf",
        basePosition=base,
        baseOrientation=list(yaw_quat(yaw)),
        useFixedBase=True,
        flags=pb.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT,
        physicsClientId=client,
    )
    for finger in FINGER_JOINTS:
        # High finger friction as on real rubber pads; torsional friction keeps long objects
        # from swinging about the finger axis.
        pb.changeDynamics(body, finger, lateralFriction=1.5, spinningFriction=0.01, physicsClientId=client)
    couple_fingers(client, body)
    robot = Panda(name, body, world_from_base)
    set_joints(client, robot, np.asarray(HOME_JOINTS), FINGER_MAX)
    hold_position(client, robot, np.asarray(HOME_JOINTS), FINGER_MAX)
    return robot


def couple_fingers(client: int, body: int) -> None:
    """Tie the two finger joints to move as one, as the real Panda hand's single drive does.

    Independent fingers let a held object sit off-centre (one finger at its 4 cm limit, the
    other squeezing), and at release the object springs sideways out of the squeeze (ADR 0011).
    The gear makes the closing fingers push the object to the hand's centre instead.

    It is weaker than one finger's drive: the real arms give a little where ours hold rigidly,
    and a gear stronger than the drive (50 N) stopped both fingers as soon as one met an object
    that cannot move to the centre (a handle the other hand holds, the pot), so the grasp
    never closed (Hammer Place and Pot Reorientation hand-overs, ADR 0011).
    """
    gear = pb.createConstraint(
        body,
        FINGER_JOINTS[0],
        body,
        FINGER_JOINTS[1],
        jointType=pb.JOINT_GEAR,
        jointAxis=[1.0, 0.0, 0.0],
        parentFramePosition=[0.0, 0.0, 0.0],
        childFramePosition=[0.0, 0.0, 0.0],
        physicsClientId=client,
    )
    pb.changeConstraint(gear, gearRatio=-1.0, erp=0.1, maxForce=FINGER_GEAR_FORCE, physicsClientId=client)


def set_joints(client: int, robot: Panda, arm: FloatArray, finger: float) -> None:
    """Kinematic reset: only when building a scene or inside the planning mirror."""
    for joint, value in zip(ARM_JOINTS, arm, strict=True):
        pb.resetJointState(robot.body, joint, float(value), physicsClientId=client)
    for joint in FINGER_JOINTS:
        pb.resetJointState(robot.body, joint, finger, physicsClientId=client)


def arm_joints(client: int, robot: Panda) -> FloatArray:
    states = pb.getJointStates(robot.body, list(ARM_JOINTS), physicsClientId=client)
    return np.array([s[0] for s in states])


def finger_positions(client: int, robot: Panda) -> tuple[float, float]:
    """Each finger's opening in metres (0 to FINGER_MAX); geared to be about equal."""
    left, right = pb.getJointStates(robot.body, list(FINGER_JOINTS), physicsClientId=client)
    return float(left[0]), float(right[0])


def finger_opening(client: int, robot: Panda) -> float:
    """Distance between the finger pads in metres (0 to 0.08)."""
    return sum(finger_positions(client, robot))


def ee_matrix(client: int, robot: Panda) -> FloatArray:
    """World pose of the end effector (link 11) as a 4x4 transform."""
    state = pb.getLinkState(robot.body, EE_LINK, computeForwardKinematics=True, physicsClientId=client)
    return pose7_to_matrix([*state[4], *state[5]])


def hold_position(client: int, robot: Panda, arm: FloatArray, finger: float) -> None:
    """Position targets for the arm and fingers (motors act on the next physics steps)."""
    pb.setJointMotorControlArray(
        robot.body,
        list(ARM_JOINTS),
        pb.POSITION_CONTROL,
        targetPositions=[float(v) for v in arm],
        forces=list(ARM_FORCES),
        positionGains=[POSITION_GAIN] * ARM_DOF,
        physicsClientId=client,
    )
    command_fingers(client, robot, finger)


def command_fingers(client: int, robot: Panda, finger: float, force: float = FINGER_FORCE) -> None:
    pb.setJointMotorControlArray(
        robot.body,
        list(FINGER_JOINTS),
        pb.POSITION_CONTROL,
        targetPositions=[finger, finger],
        forces=[force, force],
        physicsClientId=client,
    )


def joint_distance(a: FloatArray, b: FloatArray) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))))


def wrap_to_limits(arm: FloatArray) -> FloatArray:
    """Joint 7 turns by more than 2*pi within its limits; keep IK answers inside them."""
    out = np.asarray(arm, dtype=np.float64).copy()
    for i in range(ARM_DOF):
        while out[i] > UPPER_LIMITS[i] and out[i] - 2 * math.pi >= LOWER_LIMITS[i]:
            out[i] -= 2 * math.pi
        while out[i] < LOWER_LIMITS[i] and out[i] + 2 * math.pi <= UPPER_LIMITS[i]:
            out[i] += 2 * math.pi
    return out


def within_limits(arm: FloatArray) -> bool:
    return bool(np.all(arm >= LOWER_LIMITS - 1e-6) and np.all(arm <= UPPER_LIMITS + 1e-6))
