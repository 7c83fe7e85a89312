"""The simulated world: a physics client with the table, two Pandas and the scene's objects, and
a kinematic *planning mirror* of it in a second client.

Motion planning and inverse kinematics pose robots and held objects freely to test
configurations; doing that in the physics client would teleport things. They happen in the
mirror instead, which is synchronised from the physics client before each query and never
stepped. The physics client only ever moves by ``stepSimulation``; ``resetBase...`` is used
there only while building the scene.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pybullet as pb

from gfc.geometry import FloatArray, invert, matrix_to_quat, pose7_to_matrix
from gfc.kinds import object_kind
from gfc.plan.schema import Scene
from gfc.sim.bodies import BEAD_RADIUS, build_bead, build_body, build_table
from gfc.sim.panda import Panda, arm_joints, ee_matrix, finger_opening, load_panda, set_joints

TIME_STEP = 1.0 / 240.0
SOLVER_ITERATIONS = 150
# m: how far apart (or how far slid) two bodies' cached contact points may get before Bullet
# drops them. Bullet's default, 2 cm, kept points of a held block's earlier pose on the finger
# with normals of every direction: at the opening the finger dragged the block along (1-2 cm) and
# the retreat lifted it 8 cm, or the block tipped over. 1 mm keeps only the current contacts. The
# logged top-1 plans of Constrained Packing T3 (GFC, 100, packing_s24.jsonl) replayed at 2 cm:
# 77 succeed; at 1 mm: 89 (19 fixed, 7 lost; tipped blocks 12 -> 3; session 25, ADR 0015).
CONTACT_BREAKING_THRESHOLD = 0.001
SETTLE_STEPS = 120


@dataclass(frozen=True)
class SimObject:
    name: str
    kind: str
    body: int
    object_from_com: FloatArray
    fixed: bool


@dataclass(frozen=True)
class Grasp:
    """A grasp the fingers made: the contact-gated fixed constraint and where the object sits."""

    object: str
    constraint: int
    ee_from_object: FloatArray


@dataclass
class Bodies:
    """What one client holds: robots and objects by name, the table, the beads."""

    client: int
    robots: dict[str, Panda]
    objects: dict[str, SimObject]
    table: int
    beads: list[int] = field(default_factory=list)


@dataclass
class World:
    physics: Bodies
    mirror: Bodies
    grasps: dict[str, Grasp] = field(default_factory=dict)  # robot -> what it holds
    contents: dict[str, int] = field(default_factory=dict)  # container -> beads it started with
    physics_steps: int = 0

    @property
    def client(self) -> int:
        return self.physics.client

    def close(self) -> None:
        for c in (self.physics.client, self.mirror.client):
            if pb.isConnected(c):
                pb.disconnect(c)

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _populate(client: int, scene: Scene, with_mass: bool) -> Bodies:
    pb.setGravity(0.0, 0.0, -9.81, physicsClientId=client)
    pb.setPhysicsEngineParameter(
        fixedTimeStep=TIME_STEP,
        numSolverIterations=SOLVER_ITERATIONS,
        deterministicOverlappingPairs=1,
        contactBreakingThreshold=CONTACT_BREAKING_THRESHOLD,
        physicsClientId=client,
    )
    table = build_table(client)
    robots = {r.name: load_panda(client, r.name, list(r.base), r.yaw) for r in scene.robots}
    objects: dict[str, SimObject] = {}
    for spec in scene.objects:
        built = build_body(client, spec.kind, pose7_to_matrix(spec.pose), spec.fixed or not with_mass)
        objects[spec.name] = SimObject(spec.name, spec.kind, built.body, built.object_from_com, spec.fixed)
    return Bodies(client, robots, objects, table)


def _fill(bodies: Bodies, container: str, count: int) -> None:
    """Drop ``count`` beads into a container, in layers on a small grid inside its opening."""
    obj = bodies.objects[container]
    kind = object_kind(obj.kind)
    if kind.inner_half_extents is None:
        raise ValueError(f"{container!r} ({obj.kind}) is not a container and cannot hold contents")
    world_from_object = object_matrix(bodies, container)
    spacing = 2.2 * BEAD_RADIUS
    per_row = max(1, int(2 * kind.inner_half_extents[0] * 0.85 / spacing))
    for i in range(count):
        layer, cell = divmod(i, per_row * per_row)
        row, col = divmod(cell, per_row)
        offset = (per_row - 1) / 2
        local = np.array(
            [
                (col - offset) * spacing,
                (row - offset) * spacing,
                0.012 + BEAD_RADIUS + layer * spacing,
                1.0,
            ]
        )
        bodies.beads.append(build_bead(bodies.client, (world_from_object @ local)[:3]))


def build_world(scene: Scene, contents: Mapping[str, int] | None = None) -> World:
    """Build the physics world and its planning mirror for ``scene``; settle it under gravity.

    ``contents`` puts that many beads into the named containers (the liquid of a pour).
    """
    physics_client = pb.connect(pb.DIRECT)
    mirror_client = pb.connect(pb.DIRECT)
    physics = _populate(physics_client, scene, with_mass=True)
    mirror = _populate(mirror_client, scene, with_mass=False)
    for container, count in (contents or {}).items():
        _fill(physics, container, count)
    world = World(physics, mirror, contents=dict(contents or {}))
    step(world, SETTLE_STEPS)
    return world


def step(world: World, count: int = 1) -> None:
    for _ in range(count):
        pb.stepSimulation(physicsClientId=world.client)
    world.physics_steps += count


def object_matrix(bodies: Bodies, name: str) -> FloatArray:
    """``world_from_object`` of a named object (its bottom-centre frame)."""
    obj = bodies.objects[name]
    pos, quat = pb.getBasePositionAndOrientation(obj.body, physicsClientId=bodies.client)
    return pose7_to_matrix([*pos, *quat]) @ invert(obj.object_from_com)


def place_in_mirror(mirror: Bodies, name: str, world_from_object: FloatArray) -> None:
    """Pose an object of the kinematic mirror (planning only; the mirror is never stepped)."""
    obj = mirror.objects[name]
    world_from_com = world_from_object @ obj.object_from_com
    pb.resetBasePositionAndOrientation(
        obj.body,
        list(world_from_com[:3, 3]),
        list(matrix_to_quat(world_from_com[:3, :3])),
        physicsClientId=mirror.client,
    )


def sync_mirror(world: World) -> None:
    """Copy robot joints and object poses from the physics client into the planning mirror."""
    for name, robot in world.physics.robots.items():
        half = finger_opening(world.client, robot) / 2
        set_joints(world.mirror.client, world.mirror.robots[name], arm_joints(world.client, robot), half)
    for name in world.physics.objects:
        place_in_mirror(world.mirror, name, object_matrix(world.physics, name))


def entity_poses(world: World) -> dict[str, list[float]]:
    """World poses ``[x, y, z, qx, qy, qz, qw]`` of every object and every end effector."""
    out: dict[str, list[float]] = {}
    for name in world.physics.objects:
        out[name] = _pose7(object_matrix(world.physics, name))
    for name, robot in world.physics.robots.items():
        out[name] = _pose7(ee_matrix(world.client, robot))
    return out


def gripper_openings(world: World) -> dict[str, float]:
    return {name: finger_opening(world.client, r) for name, r in world.physics.robots.items()}


def bead_positions(world: World) -> list[FloatArray]:
    return [
        np.asarray(pb.getBasePositionAndOrientation(b, physicsClientId=world.client)[0])
        for b in world.physics.beads
    ]


def _pose7(mat: FloatArray) -> list[float]:
    return [float(v) for v in (*mat[:3, 3], *matrix_to_quat(mat[:3, :3]))]


def yaw_of(mat: FloatArray) -> float:
    return math.atan2(mat[1, 0], mat[0, 0])
