"""A world reset in place for a new scene looks like a fresh build of that scene."""

from __future__ import annotations

import numpy as np
import pytest

from gfc.data.scenarios import SCENARIOS, grasp_proposal
from gfc.sim.execute import execute_in_world
from gfc.sim.panda import HOME_JOINTS, arm_joints
from gfc.sim.reuse import WorldCache, structure_key
from gfc.sim.world import entity_poses


@pytest.mark.slow
def test_a_reset_world_shows_the_new_scene_at_rest_with_the_arms_home() -> None:
    rng = np.random.default_rng(0)
    first, second = SCENARIOS["pick.cube"](rng), SCENARIOS["pick.cube"](rng)
    assert structure_key(first.plan.scene) == structure_key(second.plan.scene)
    cache = WorldCache()
    world = cache.acquire(first.plan.scene)
    outcome = execute_in_world(world, first.plan, [grasp_proposal("cube", rng)], seed=0)
    assert outcome.steps[0].success and world.grasps  # the cube is in a hand, lifted
    cache.release(world, first.plan.scene)
    again = cache.acquire(second.plan.scene)
    try:
        assert again is world and cache.reused == 1
        assert not again.grasps
        cube = entity_poses(again)["obj"]
        assert np.allclose(cube[:3], second.plan.scene.objects[0].pose[:3], atol=0.003)
        for robot in again.physics.robots.values():
            assert np.allclose(arm_joints(again.client, robot), HOME_JOINTS, atol=0.01)
        fresh = execute_in_world(again, second.plan, [grasp_proposal("cube", rng)], seed=0)
        assert fresh.steps[0].success, fresh.steps[0].reason  # and it works as a scene
    finally:
        cache.release(again, second.plan.scene)
        cache.close()
