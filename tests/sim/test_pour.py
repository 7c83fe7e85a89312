"""The pour is judged against what the source started with: beads lost on the way (spilled while
carrying) count as spilled, not only those that miss the target during the pour; so carries keep
a container with contents upright."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gfc.sim.collision import UPRIGHT_TILT, Collision, make_collision_fn
from gfc.sim.execute import execute_in_world
from gfc.sim.skills.grasping import pick
from gfc.sim.skills.motions import LEAN_MARGIN, SkillContext, carried_by, collision_fn, joints, upright_limit
from gfc.sim.world import build_world
from gfc.tasks import sample_task


@pytest.mark.slow
def test_a_pour_must_land_most_of_what_the_source_started_with() -> None:
    instance = sample_task("pour_cup", 0)
    actions = [None if a is None else np.asarray(a) for a in instance.reference_actions]
    with build_world(instance.plan.scene, instance.contents) as world:
        held = world.contents["mug"]
        # The same six beads, but the record says the mug started with more: as if four had been
        # lost before the pour. Landing all six is then 6 of 10, under the 80 % share.
        world.contents["mug"] = held + 4
        outcome = execute_in_world(world, instance.plan, actions, seed=0)
    last = outcome.steps[-1]
    assert last.skill == "pour" and not last.success
    assert f"of {held + 4} beads" in last.reason


@pytest.mark.slow
def test_a_held_container_with_contents_must_stay_upright_in_motion_planning() -> None:
    instance = sample_task("pour_cup", 0)
    pick_mug = instance.plan.skeleton[0]
    with build_world(instance.plan.scene, instance.contents) as world:
        ctx = SkillContext(world, np.random.default_rng(0))
        pick(ctx, pick_mug, np.asarray(instance.reference_actions[0]))
        carried = carried_by(ctx, ["left"])
        plain = make_collision_fn(world, ["left"], carried, {"left": 0.0})
        upright = make_collision_fn(world, ["left"], carried, {"left": 0.0}, upright={"mug": UPRIGHT_TILT})
        q = joints(ctx, "left")
        assert upright(q) is None, "the mug is upright after the pick"
        # The side grasp's approach axis is horizontal: turning the last joint (about that axis)
        # tips the mug over sideways.
        tipped = q.copy()
        tipped[6] += 0.6 if tipped[6] < 2.2 else -0.6
        assert plain(tipped) is None, "nothing else is hit: only the tilt can be the reason"
        assert upright(tipped) == Collision("mug", "tilt")
        # The executors' checker keeps it upright by itself: the mug holds beads.
        assert collision_fn(ctx, ["left"])(tipped) == Collision("mug", "tilt")


def test_a_leaning_container_may_tilt_a_little_further_than_it_leans() -> None:
    assert upright_limit(np.eye(4)) == pytest.approx(UPRIGHT_TILT)
    leaning = np.eye(4)
    angle = math.radians(40.0)
    leaning[:3, :3] = [
        [1, 0, 0],
        [0, math.cos(angle), -math.sin(angle)],
        [0, math.sin(angle), math.cos(angle)],
    ]
    assert upright_limit(leaning) == pytest.approx(angle + LEAN_MARGIN)
