"""The world builder: robots where the plan says, home pose as gfc.kinds states, objects at their
poses and at rest, no global client."""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb

from gfc.geometry import invert, pose7_to_matrix
from gfc.kinds import HOME_EE_POSE_IN_BASE, OBJECT_KINDS
from gfc.plan.schema import PlanRequest, Scene
from gfc.sim.bodies import TABLE_TOP_Z
from gfc.sim.panda import ee_matrix
from gfc.sim.world import World, build_world, entity_poses, gripper_openings, object_matrix


def test_home_pose_matches_forward_kinematics(
    hammer_place_world: tuple[World, PlanRequest],
) -> None:
    world, _ = hammer_place_world
    for robot in world.physics.robots.values():
        base_from_ee = invert(robot.world_from_base) @ ee_matrix(world.client, robot)
        expected = pose7_to_matrix(HOME_EE_POSE_IN_BASE)
        assert np.linalg.norm(base_from_ee[:3, 3] - expected[:3, 3]) < 0.002
        cos = (np.trace(base_from_ee[:3, :3].T @ expected[:3, :3]) - 1) / 2
        assert math.degrees(math.acos(min(1.0, cos))) < 1.0


def test_objects_rest_where_the_scene_puts_them(
    hammer_place_world: tuple[World, PlanRequest],
) -> None:
    world, plan = hammer_place_world
    for spec in plan.scene.objects:
        settled = object_matrix(world.physics, spec.name)
        assert np.linalg.norm(settled[:3, 3] - np.asarray(spec.pose[:3])) < 0.005, spec.name


def test_every_kind_builds_and_stands_on_the_table() -> None:
    objects = [
        {
            "name": f"o_{kind}",
            "kind": kind,
            "pose": [0.25 + 0.45 * (i % 2), -0.8 + 0.3 * (i // 2), TABLE_TOP_Z, 0, 0, 0, 1],
        }
        for i, kind in enumerate(sorted(OBJECT_KINDS))
    ]
    scene = Scene.model_validate(
        {"robots": [{"name": "left", "base": [-0.3, 0.0, TABLE_TOP_Z]}], "objects": objects}
    )
    with build_world(scene) as world:
        for spec in scene.objects:
            rest = object_matrix(world.physics, spec.name)
            assert abs(rest[2, 3] - TABLE_TOP_Z) < 0.004, spec.kind
            assert rest[2, 2] > math.cos(math.radians(3.0)), f"{spec.kind} tipped over"


def test_poses_and_grippers_are_reported_for_every_entity(
    hammer_place_world: tuple[World, PlanRequest],
) -> None:
    world, plan = hammer_place_world
    poses = entity_poses(world)
    assert set(poses) == {o.name for o in plan.scene.objects} | {"left", "right"}
    assert all(len(p) == 7 for p in poses.values())
    assert gripper_openings(world) == {"left": 0.08, "right": 0.08} or all(
        abs(v - 0.08) < 1e-3 for v in gripper_openings(world).values()
    )


def test_worlds_are_independent_clients() -> None:
    scene = PlanRequest.model_validate(
        {
            "scene": {"robots": [{"name": "a", "base": [0, 0, TABLE_TOP_Z]}]},
            "skeleton": [{"skill": "move", "robot": "a"}],
        }
    ).scene
    with build_world(scene) as first, build_world(scene) as second:
        assert first.client != second.client
        assert first.mirror.client not in (first.client, second.client)
    assert not pb.isConnected(first.client)
