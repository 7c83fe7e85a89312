"""OMPL motion planning on the planning mirror: paths avoid obstacles, replay exactly, and the
physics client is never touched while planning."""

from __future__ import annotations

import numpy as np
import pytest

from gfc.plan.schema import Scene
from gfc.sim.bodies import TABLE_TOP_Z
from gfc.sim.collision import Collision, first_collision_on_segment, make_collision_fn, self_collision_fn
from gfc.sim.control import tracks_lines
from gfc.sim.ik import solve_ik
from gfc.sim.motion import plan_motion
from gfc.sim.panda import HOME_JOINTS, arm_joints
from gfc.sim.world import World, build_world, entity_poses
from gfc.tasks.base import frame

# A rack (a bar on two legs, 12 cm high) right under the left hand's way from one side to the other.
SCENE = Scene.model_validate(
    {
        "robots": [
            {"name": "left", "base": [0.0, 0.35, TABLE_TOP_Z]},
            {"name": "right", "base": [0.0, -0.35, TABLE_TOP_Z]},
        ],
        "objects": [
            {"name": "rack", "kind": "rack", "pose": [0.45, 0.35, TABLE_TOP_Z, 0, 0, 0, 1], "fixed": True}
        ],
    }
)
DOWN = np.diag([1.0, -1.0, -1.0])


def _goals(world: World) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    home = np.asarray(HOME_JOINTS)
    near = solve_ik(world, "left", frame([0.45, 0.76, TABLE_TOP_Z + 0.05], DOWN), home, rng)
    far = solve_ik(world, "left", frame([0.45, -0.06, TABLE_TOP_Z + 0.05], DOWN), home, rng)
    assert near is not None and far is not None
    return near, far


@pytest.mark.slow
def test_rrt_connect_goes_around_the_rack_and_replays_exactly() -> None:
    with build_world(SCENE) as world:
        check = make_collision_fn(world, ["left"])
        start, goal = _goals(world)
        assert first_collision_on_segment(check, start, goal) is not None, "the direct path must be blocked"
        before = entity_poses(world)
        joints_before = arm_joints(world.client, world.physics.robots["left"])
        first = plan_motion(check, start, goal, np.random.default_rng(3))
        second = plan_motion(check, start, goal, np.random.default_rng(3))
        assert first.path is not None and second.path is not None
        assert "RRTConnect" in first.reason
        np.testing.assert_array_equal(np.stack(first.path), np.stack(second.path))
        for a, b in zip(first.path[:-1], first.path[1:], strict=True):
            assert first_collision_on_segment(check, a, b, resolution=0.01) is None
        np.testing.assert_allclose(first.path[0], start)
        np.testing.assert_allclose(first.path[-1], goal)
        assert entity_poses(world) == before, "planning must not move anything in the physics client"
        np.testing.assert_array_equal(arm_joints(world.client, world.physics.robots["left"]), joints_before)
        # The search budget is counted in collision checks (not seconds): none left, it gives up, whatever
        # the machine's load.
        starved = plan_motion(check, start, goal, np.random.default_rng(3), max_checks=1)
        assert starved.path is None and "1 collision checks" in starved.reason


def test_goal_inside_an_obstacle_is_reported() -> None:
    with build_world(SCENE) as world:
        check = make_collision_fn(world, ["left"])
        inside = solve_ik(
            world,
            "left",
            frame([0.45, 0.35, TABLE_TOP_Z + 0.11], DOWN),
            np.asarray(HOME_JOINTS),
            np.random.default_rng(0),
        )
        assert inside is not None
        result = plan_motion(check, np.asarray(HOME_JOINTS), inside, np.random.default_rng(0))
        assert result.path is None
        assert "goal in collision" in result.reason and "rack" in result.reason


def test_an_arm_folded_onto_itself_is_in_collision() -> None:
    """Configurations within the joint limits can fold the hand back into the arm."""
    with build_world(SCENE) as world:
        check = make_collision_fn(world, ["right"])
        assert check(np.asarray(HOME_JOINTS)) is None
        folded = np.asarray(HOME_JOINTS).copy()
        folded[3] = -2.84  # elbow folded further than at home
        folded[5] = 0.78  # and the wrist tipped back: the fingers reach the shoulder
        hit = check(folded)
        assert hit is not None and hit.other.startswith("itself"), hit


def test_a_carried_object_keeps_the_clearance_asked_for() -> None:
    """The left hand carries a block (held at its centre) with its bottom 5 mm over the rack's
    bar: it touches nothing, so there is no collision without a clearance, and a collision with
    the rack within 1 cm; 3 cm over the bar it is clear either way. The hand holding it never
    counts."""
    from gfc.geometry import invert
    from gfc.sim.collision import Carried

    scene = SCENE.model_dump()
    scene["objects"].append({"name": "block", "kind": "block", "pose": [0.3, 0.0, TABLE_TOP_Z, 0, 0, 0, 1]})
    bar_top = TABLE_TOP_Z + 0.12
    with build_world(Scene.model_validate(scene)) as world:
        for gap, expected in ((0.005, "rack (within 1 cm)"), (0.03, None)):
            world_from_block = frame([0.45, 0.35, bar_top + gap], np.eye(3))
            world_from_ee = frame([0.45, 0.35, bar_top + gap + 0.025], DOWN)
            q = solve_ik(world, "left", world_from_ee, np.asarray(HOME_JOINTS), np.random.default_rng(0))
            assert q is not None
            carried = [Carried("left", "block", invert(world_from_ee) @ world_from_block)]
            assert make_collision_fn(world, ["left"], carried, {"left": 0.05})(q) is None
            hit = make_collision_fn(world, ["left"], carried, {"left": 0.05}, clearance=0.01)(q)
            assert (hit.other if hit else None) == expected
            if hit:
                assert hit.moving == "block"


@pytest.mark.slow
def test_a_carried_object_in_a_fixed_one_is_a_collision() -> None:
    """Objects on the planning mirror are all static, and Bullet reports no contact between two
    static bodies: a carried block pushed 2 cm into the rack's bar must still be a collision
    (it was not before session 20), 1 mm in is resting contact, and an allowed pair is free."""
    from gfc.geometry import invert
    from gfc.sim.collision import PENETRATION_TOLERANCE, Carried

    scene = SCENE.model_dump()
    scene["objects"].append({"name": "block", "kind": "block", "pose": [0.3, 0.0, TABLE_TOP_Z, 0, 0, 0, 1]})
    bar_top = TABLE_TOP_Z + 0.12
    assert PENETRATION_TOLERANCE > 0.001
    with build_world(Scene.model_validate(scene)) as world:
        for depth, allowed, expected in (
            (0.02, frozenset(), "rack"),
            (0.001, frozenset(), None),
            (0.02, frozenset({("block", "rack")}), None),
        ):
            world_from_block = frame([0.45, 0.35, bar_top - depth], np.eye(3))
            world_from_ee = frame([0.45, 0.35, bar_top - depth + 0.025], DOWN)
            q = solve_ik(world, "left", world_from_ee, np.asarray(HOME_JOINTS), np.random.default_rng(0))
            assert q is not None
            carried = [Carried("left", "block", invert(world_from_ee) @ world_from_block)]
            hit = make_collision_fn(world, ["left"], carried, {"left": 0.05}, allowed)(q)
            assert (None if hit is None else (hit.moving, hit.other)) == (
                None if expected is None else ("block", expected)
            ), f"{depth * 100:.1f} cm into the bar, allowed {set(allowed)}"


def test_the_self_collision_test_sees_the_arm_alone_and_guards_tracked_lines() -> None:
    """``self_collision_fn`` finds the folded arm and nothing else; a straight line tracked from
    a free configuration fails ``tracks_lines`` once its guard refuses a waypoint."""
    with build_world(SCENE) as world:
        check = self_collision_fn(world, "right")
        home = np.asarray(HOME_JOINTS)
        assert check(home) is None
        folded = home.copy()
        folded[3], folded[5] = -2.84, 0.78
        hit = check(folded)
        assert hit is not None and hit.other.startswith("itself"), hit
        rng = np.random.default_rng(0)
        start = world.mirror.robots["right"].world_from_base @ frame(
            [0.45, 0.0, 0.3], np.diag([1.0, -1.0, -1.0])
        )
        q = solve_ik(world, "right", start, home, rng)
        assert q is not None
        lifted = start.copy()
        lifted[2, 3] += 0.05
        assert tracks_lines(world, "right", q, [start, lifted], rng, guard=check)
        assert not tracks_lines(
            world, "right", q, [start, lifted], rng, guard=lambda _: Collision("right", "x")
        )


def test_the_open_hand_keeps_the_clearance_asked_for_from_objects_not_the_table() -> None:
    """The left open hand pointing down, one finger over a nail: where its nearest link is
    within 1 cm of the nail, a hand clearance of 1 cm makes it a collision with the nail; higher
    up, or without the clearance, it is free. The table never counts (the hand rests its fingers
    near it at every low grasp), nor does an object the hand carries."""
    import pybullet as pb

    from gfc.geometry import invert
    from gfc.sim.collision import Carried
    from gfc.sim.panda import HAND_LINKS, set_joints

    scene = SCENE.model_dump()
    scene["objects"] = [{"name": "nail", "kind": "nail", "pose": [0.45, 0.6, TABLE_TOP_Z, 0, 0, 0, 1]}]
    nail_top = TABLE_TOP_Z + 0.08
    with build_world(Scene.model_validate(scene)) as world:
        mirror = world.mirror
        seen = set()
        for above in (0.01, 0.015, 0.02, 0.025, 0.03, 0.07):
            # The fingers open along the hand's y (the world's -y here): one finger over the nail.
            world_from_ee = frame([0.45, 0.6 + 0.045, nail_top + above], DOWN)
            q = solve_ik(world, "left", world_from_ee, np.asarray(HOME_JOINTS), np.random.default_rng(0))
            assert q is not None
            set_joints(mirror.client, mirror.robots["left"], q, 0.04)
            points = pb.getClosestPoints(
                mirror.robots["left"].body, mirror.objects["nail"].body, 0.5, physicsClientId=mirror.client
            )
            gap = min(p[8] for p in points if p[3] in HAND_LINKS)
            assert gap > -0.002  # no collision at all without a clearance
            assert make_collision_fn(world, ["left"], fingers={"left": 0.08})(q) is None
            hit = make_collision_fn(world, ["left"], fingers={"left": 0.08}, hand_clearance=0.01)(q)
            expected = "nail (the hand within 1 cm)" if gap < 0.01 else None
            assert (hit.other if hit else None) == expected, gap
            seen.add(expected)
            # Carried, the nail may be as close as it likes to the hand holding it.
            world_from_nail = frame([0.45, 0.6, TABLE_TOP_Z], np.eye(3))
            carried = [Carried("left", "nail", invert(world_from_ee) @ world_from_nail)]
            held = make_collision_fn(world, ["left"], carried, {"left": 0.08}, hand_clearance=0.01)(q)
            assert held is None or "nail (the hand" not in held.other
        assert seen == {"nail (the hand within 1 cm)", None}  # both sides of the margin were tried
        # Low over the bare table: the table does not count.
        world_from_ee = frame([0.30, 0.45, TABLE_TOP_Z + 0.02], DOWN)
        q = solve_ik(world, "left", world_from_ee, np.asarray(HOME_JOINTS), np.random.default_rng(0))
        assert q is not None
        assert make_collision_fn(world, ["left"], fingers={"left": 0.08}, hand_clearance=0.01)(q) is None
