"""Two arms moving at once to separate targets: when every pair of the arms' IK solutions (each
solved with the other arm ignored) collides, one arm's goal is solved again beside the other."""

from __future__ import annotations

import numpy as np
import pytest

from gfc.sim.ik import ANGLE_TOLERANCE, POSITION_TOLERANCE, pose_error, solve_ik
from gfc.sim.panda import FINGER_MAX, LOWER_LIMITS, UPPER_LIMITS, ee_matrix, set_joints
from gfc.sim.skills.bimanual import _free_pair
from gfc.sim.skills.grasping import pick
from gfc.sim.skills.motions import SkillContext, collision_fn, free_ik_solutions
from gfc.sim.skills.moving import hand_target
from gfc.sim.world import build_world
from gfc.tasks import sample_task


@pytest.mark.slow
def test_colliding_solutions_of_two_move_targets_are_replaced_by_a_free_pair() -> None:
    instance = sample_task("pour_cup", 0)
    plan, actions = instance.plan, [None if a is None else np.asarray(a) for a in instance.reference_actions]
    with build_world(plan.scene, instance.contents) as world:
        ctx = SkillContext(world, np.random.default_rng(0))
        for step, action in zip(plan.skeleton[:2], actions[:2], strict=True):  # the two picks
            assert action is not None
            pick(ctx, step, action)
        robots = ["left", "right"]
        targets = []
        for step, action in zip(plan.skeleton[2:4], actions[2:4], strict=True):  # the meeting
            assert action is not None
            targets.append(hand_target(world, step.robot, step.object, action))
        left = free_ik_solutions(ctx, "left", targets[0], collision_fn(ctx, ["left"], _all_pairs()), "left")
        both = collision_fn(ctx, robots)
        # A solution of the right arm's target that meets the left arm at its first solution
        # (found from random starts; the scene, and so the search, is the same every run).
        rng = np.random.default_rng(1)
        clash = None
        for _ in range(400):
            q = solve_ik(world, "right", targets[1], rng.uniform(LOWER_LIMITS, UPPER_LIMITS), rng, restarts=0)
            if q is not None and both(np.concatenate([left[0], q])) is not None:
                clash = q
                break
        assert clash is not None, "no right-arm solution meets the left arm: pick another scene"
        pair = _free_pair(ctx, robots, targets, [left[:1], [clash]])
        assert both(np.concatenate(pair)) is None, "the pair returned is free together"
        for q, robot, target in zip(pair, robots, targets, strict=True):
            set_joints(world.mirror.client, world.mirror.robots[robot], q, FINGER_MAX)
            dp, da = pose_error(ee_matrix(world.mirror.client, world.mirror.robots[robot]), target)
            assert dp < POSITION_TOLERANCE and da < ANGLE_TOLERANCE, (
                f"{robot}'s joints put its hand at its target"
            )


def _all_pairs() -> frozenset[tuple[str, str]]:
    """Contacts between the left arm (with the mug) and the right arm (with the cup) allowed."""
    return frozenset((a, b) for a in ("left", "mug") for b in ("right", "cup"))
