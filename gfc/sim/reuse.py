"""Reuse a built world for the next scene of the same structure (data collection's hot loop).

Building a world loads four Panda URDFs (two in the physics client, two in the planning mirror):
about 0.2 s, a quarter of a typical collection attempt. Consecutive attempts of one scenario
have the same robots and the same object kinds, only at other poses, so a worker can keep its
world and *rebuild the scene in place*: drop the grasp constraints, put the arms back at home
(joints and motor targets), put every object at its new pose at rest, and settle under gravity as
a fresh build does. This is scene construction, as in ``build_world``; no object is moved
while a skill runs.

A reset world is not bit-identical to a fresh one (the solver's warm-start caches remember the
previous attempt), so results are reproducible per worker history, not per attempt seed. Data
collection and skill checks accept that; ``execute_plan`` (verification, benchmarks) always
builds fresh.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pybullet as pb

from gfc.geometry import matrix_to_quat, pose7_to_matrix
from gfc.plan.schema import Scene
from gfc.sim.panda import FINGER_MAX, HOME_JOINTS, hold_position, set_joints
from gfc.sim.world import SETTLE_STEPS, Bodies, World, build_world, step

StructureKey = tuple[object, ...]


def structure_key(scene: Scene) -> StructureKey:
    robots = tuple((r.name, tuple(r.base), r.yaw) for r in scene.robots)
    objects = tuple((o.name, o.kind, o.fixed) for o in scene.objects)
    return robots, objects


def _place_objects(bodies: Bodies, scene: Scene, physics: bool) -> None:
    for spec in scene.objects:
        obj = bodies.objects[spec.name]
        world_from_com = pose7_to_matrix(spec.pose) @ obj.object_from_com
        pb.resetBasePositionAndOrientation(
            obj.body,
            list(world_from_com[:3, 3]),
            list(matrix_to_quat(world_from_com[:3, :3])),
            physicsClientId=bodies.client,
        )
        if physics:
            pb.resetBaseVelocity(obj.body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=bodies.client)


def reset_world(world: World, scene: Scene) -> None:
    """Rebuild ``scene`` in a world built for a scene of the same structure."""
    for grasp in world.grasps.values():
        pb.removeConstraint(grasp.constraint, physicsClientId=world.client)
    world.grasps.clear()
    home = np.asarray(HOME_JOINTS)
    for bodies in (world.physics, world.mirror):
        for robot in bodies.robots.values():
            set_joints(bodies.client, robot, home, FINGER_MAX)
    for robot in world.physics.robots.values():
        hold_position(world.client, robot, home, FINGER_MAX)
    _place_objects(world.physics, scene, physics=True)
    _place_objects(world.mirror, scene, physics=False)
    step(world, SETTLE_STEPS)


class WorldCache:
    """One world per scene structure, kept between attempts of one worker process."""

    def __init__(self, limit: int = 2) -> None:
        self.limit = limit
        self._worlds: dict[StructureKey, World] = {}
        self.built = 0
        self.reused = 0

    def acquire(self, scene: Scene, contents: Mapping[str, int] | None = None) -> World:
        """A world showing ``scene``: a kept one reset in place, or a new one. Worlds with
        contents (beads) are always new: beads are loose bodies that a reset cannot account for."""
        key = structure_key(scene)
        world = None if contents else self._worlds.pop(key, None)
        if world is not None:
            reset_world(world, scene)
            self.reused += 1
            return world
        self.built += 1
        return build_world(scene, contents)

    def release(self, world: World, scene: Scene, reusable: bool = True) -> None:
        """Keep ``world`` for the next scene of its structure (or close it)."""
        key = structure_key(scene)
        if not reusable or world.physics.beads or key in self._worlds:
            world.close()
            return
        if len(self._worlds) >= self.limit:
            _, oldest = self._worlds.popitem()
            oldest.close()
        self._worlds[key] = world

    def close(self) -> None:
        for world in self._worlds.values():
            world.close()
        self._worlds.clear()
