"""A hand-over's approach is a straight line that ends touching the object the other hand holds;
``clear_of_other_arms`` is the test that line must pass: the receiving arm may touch objects and
the table, not the giving arm (forearms meeting on the way in stopped the hand short and the
fingers closed on nothing: most of Hammer Nail's GFC failures at 128 candidates)."""

from __future__ import annotations

import numpy as np

from gfc.sim.ik import solve_ik
from gfc.sim.panda import FINGER_MAX, HOME_JOINTS, set_joints
from gfc.sim.skills.motions import SkillContext, clear_of_other_arms, collision_fn
from gfc.sim.world import build_world
from gfc.tasks import sample_task
from gfc.tasks.base import TABLE_Z


def test_the_handover_line_guard_stops_at_the_other_arm_and_lets_objects_be_touched() -> None:
    instance = sample_task("hammer_place", 0)
    with build_world(instance.plan.scene) as world:
        ctx = SkillContext(world, np.random.default_rng(0))
        guard = clear_of_other_arms(ctx, "right")
        assert guard(np.asarray(HOME_JOINTS, dtype=np.float64)) is None
        # The left hand held between the bases, the right hand brought to the same point: the
        # arms meet.
        between = np.diag([1.0, -1.0, -1.0, 1.0])
        between[:3, 3] = (0.45, 0.0, 0.95)
        left = solve_ik(world, "left", between, np.asarray(HOME_JOINTS), ctx.rng, restarts=20)
        assert left is not None
        set_joints(world.client, world.physics.robots["left"], left, FINGER_MAX)
        guard = clear_of_other_arms(ctx, "right")  # made after the move: it reads the arms now
        into_left = solve_ik(world, "right", between, np.asarray(HOME_JOINTS), ctx.rng, restarts=20)
        assert into_left is not None
        hit = guard(into_left)
        assert hit is not None and hit.other == "left"
        # The right hand's fingertips 1 cm into the table: the plain check refuses it, the line
        # guard lets it touch (the approach ends on an object, which may rest on something).
        into_table = np.diag([1.0, -1.0, -1.0, 1.0])
        into_table[:3, 3] = (0.45, -0.25, TABLE_Z - 0.01)
        q = solve_ik(world, "right", into_table, np.asarray(HOME_JOINTS), ctx.rng, restarts=20)
        assert q is not None
        plain = collision_fn(ctx, ["right"])(q)
        assert plain is not None and plain.other == "table"
        assert guard(q) is None
