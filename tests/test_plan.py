"""Plan schema and compiler: the example compiles as expected, every invalid case is located."""

from __future__ import annotations

import copy
import json
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gfc.examples import load_example
from gfc.kinds import OBJECT_KINDS
from gfc.plan import PlanError, compile_plan, load_plan, parse_plan
from gfc.tasks import sample_task


def example() -> dict[str, Any]:
    return load_example("hammer_place")


def errors_of(plan: dict[str, Any]) -> list[tuple[str, str]]:
    with pytest.raises(PlanError) as info:
        compile_plan(plan)
    return [(i.loc, i.message) for i in info.value.issues]


def test_example_compiles_to_expected_node_versions() -> None:
    graph = compile_plan(example())
    summary = graph.summary()
    assert summary["node_versions"] == [
        "left@0", "right@0", "hammer@0", "box@0",  # the observed scene
        "left@1", "hammer@1",  # pick
        "left@2", "hammer@2",  # move
        "right@1", "hammer@3", "left@3",  # regrasp (handover): all three change
        "right@2", "hammer@4",  # place
    ]  # fmt: skip
    assert summary["known_nodes"] == ["left@0", "right@0", "hammer@0", "box@0"]
    pre_effect = [(f["model"], f["pre"], f["effect"]) for f in summary["temporal_factors"]]
    assert pre_effect == [
        ("pick.hammer", ["left@0", "hammer@0"], ["left@1", "hammer@1"]),
        ("move.hammer", ["left@1", "hammer@1"], ["left@2", "hammer@2"]),
        ("regrasp.hammer", ["right@0", "hammer@2", "left@2"], ["right@1", "hammer@3", "left@3"]),
        ("place.hammer.box", ["right@1", "hammer@3", "box@0"], ["right@2", "hammer@4"]),
    ]
    # The compiler implies physics of its own: every hand it samples within its arm's reach, and
    # at the hand-over the receiver's grasp (step 2's action) clear of the giver's (step 0's).
    assert summary["spatial_factors"] == [
        {"type": "reach", "source": "implied", "index": 0, "nodes": ["left@1"]},
        {"type": "reach", "source": "implied", "index": 1, "nodes": ["left@2"]},
        {"type": "reach", "source": "implied", "index": 2, "nodes": ["right@1"]},
        {"type": "reach", "source": "implied", "index": 3, "nodes": ["left@3"]},
        {"type": "grasps_apart", "source": "implied", "index": 4, "nodes": [], "actions_of_steps": [0, 2]},
        {"type": "reach", "source": "implied", "index": 5, "nodes": ["right@2"]},
        {"type": "placed_reach", "source": "implied", "index": 6, "nodes": ["box@0"], "actions_of_steps": [3]},
        {"type": "inside", "source": "goal", "index": 0, "nodes": ["hammer@4", "box@0"]},
    ]  # fmt: skip
    # With the kinematic links on, the skills imply two more factors: the hammer stays put in the
    # moving hand; the place's action is where the hammer rests in the box.
    linked = compile_plan({**example(), "options": {"kinematics": True}}).summary()
    assert [f for f in linked["spatial_factors"] if f["type"] not in ("reach", "grasps_apart", "placed_reach")] == [
        {"type": "fixed_transform", "source": "implied", "index": 2, "nodes": ["left@1", "hammer@1", "left@2", "hammer@2"]},
        {"type": "relative_pose", "source": "implied", "index": 7, "nodes": ["box@0", "hammer@4"], "actions_of_steps": [3]},
        {"type": "inside", "source": "goal", "index": 0, "nodes": ["hammer@4", "box@0"]},
    ]  # fmt: skip
    assert summary["shared_nodes"] == [
        "hammer@1",
        "hammer@2",
        "hammer@3",
        "left@1",
        "left@2",
        "right@1",
    ]
    # Known nodes carry the scene in the world frame (pose9, robots with the gripper opening).
    hammer0 = graph.node("hammer@0")
    assert hammer0.value is not None and hammer0.value[:3] == pytest.approx((0.45, 0.25, 0.64))
    left0 = graph.node("left@0")
    assert left0.value is not None and left0.value[1] == pytest.approx(0.35) and left0.value[9] == 0.08


def test_group_shares_one_new_version_of_a_jointly_held_object() -> None:
    plan = {
        "scene": {
            "robots": [
                {"name": "left", "base": [0, 0.35, 0.625]},
                {"name": "right", "base": [0, -0.35, 0.625]},
            ],
            "objects": [{"name": "pot", "kind": "pot", "pose": [0.5, 0, 0.625, 0, 0, 0, 1]}],
        },
        "skeleton": [
            {"skill": "pick", "robot": "left", "object": "pot", "group": "grasp"},
            {"skill": "pick", "robot": "right", "object": "pot", "group": "grasp"},
            {"skill": "move", "robot": "left", "object": "pot", "group": "turn"},
            {"skill": "move", "robot": "right", "object": "pot", "group": "turn"},
        ],
        "constraints": [
            {
                "type": "fixed_transform",
                "object": "left",
                "target": "right",
                "at": ["grasp", "turn"],
            }
        ],
        "goal": [{"type": "yaw", "object": "pot", "yaw_deg": 45}],
    }
    graph = compile_plan(plan)
    effects = [
        [graph.nodes[t.node].label for t in f.tokens if t.phase == "effect" and t.node is not None]
        for f in graph.temporal
    ]
    assert effects == [
        ["left@1", "pot@1"],
        ["right@1", "pot@1"],
        ["left@2", "pot@2"],
        ["right@2", "pot@2"],
    ]
    assert graph.temporal_degree()[graph.node("pot@1").id] == 4  # effect of both picks, pre of both moves
    assert graph.stages == ((0, 1), (2, 3))
    # Carrying the pot with both hands: the compiler adds physics itself, besides the plan's own
    # constraint and goal: the two hands keep their relative pose (the closed chain) and, with the
    # kinematic links on, each hand keeps the pot where it holds it.
    linked = compile_plan({**plan, "options": {"kinematics": True}})
    implied = [f for f in linked.spatial if f.source == "implied" and f.type != "reach"]
    assert [(f.type, [linked.nodes[n].label for n in f.nodes]) for f in implied] == [
        ("fixed_transform", ["left@1", "pot@1", "left@2", "pot@2"]),
        ("fixed_transform", ["right@1", "pot@1", "right@2", "pot@2"]),
        ("fixed_transform", ["left@1", "right@1", "left@2", "right@2"]),
    ]
    # By default (links off) the closed chain stays.
    assert [
        [graph.nodes[n].label for n in f.nodes]
        for f in graph.spatial
        if f.source == "implied" and f.type != "reach"
    ] == [["left@1", "right@1", "left@2", "right@2"]]
    plan["skeleton"] = plan["skeleton"][:2]  # a two-handed pick alone: nothing held through a move yet
    plan["constraints"], plan["goal"] = [], []
    assert not [f for f in compile_plan(plan).spatial if f.source == "implied" and f.type != "reach"]


def test_a_place_links_its_action_to_where_the_object_rests() -> None:
    plan = {
        "scene": {
            "robots": [{"name": "left", "base": [0, 0.35, 0.625]}],
            "objects": [
                {"name": "cube", "kind": "cube", "pose": [0.5, 0.3, 0.625, 0, 0, 0, 1]},
                {"name": "box", "kind": "box", "pose": [0.5, 0.0, 0.625, 0, 0, 0, 1], "fixed": True},
            ],
        },
        "skeleton": [
            {"skill": "pick", "robot": "left", "object": "cube"},
            {"skill": "place", "robot": "left", "object": "cube", "target": "box"},
        ],
        "options": {"kinematics": True},
    }
    graph = compile_plan(plan)
    (link,) = [f for f in graph.spatial if f.source == "implied" and f.type == "relative_pose"]
    place_action = next(a for a in graph.actions if a.step == 1)
    assert link.type == "relative_pose"
    assert [graph.nodes[n].label for n in link.nodes] == ["box@0", "cube@2"]
    assert link.actions == (place_action.id,)


@pytest.mark.parametrize(
    ("mutate", "loc", "fragment"),
    [
        (
            lambda p: p["skeleton"][0].update(skill="teleport"),
            "skeleton[0].skill",
            "unknown skill 'teleport'",
        ),
        (
            lambda p: p["skeleton"][0].update(object="anvil"),
            "skeleton[0].object",
            "'anvil' is not in the scene",
        ),
        (
            lambda p: p["skeleton"][1].update(robot="middle"),
            "skeleton[1].robot",
            "'middle' is not in the scene",
        ),
        (
            lambda p: p["skeleton"][0].update(robot="hammer"),
            "skeleton[0].robot",
            "an object, not a robot",
        ),
        # a robot that moves an object it does not hold
        (
            lambda p: p["skeleton"][1].update(robot="right"),
            "skeleton[1].object",
            "robot 'right' does not hold 'hammer'",
        ),
        (
            lambda p: p["skeleton"][2].update(**{"from": "right", "robot": "left"}),
            "skeleton[2].robot",
            "already holds 'hammer'",
        ),
        # an object picked twice without release
        (
            lambda p: p["skeleton"].insert(1, {"skill": "pick", "robot": "right", "object": "hammer"}),
            "skeleton[1].object",
            "cannot be picked twice without being released",
        ),
        (
            lambda p: p["skeleton"][0].update(object="box"),
            "skeleton[0].object",
            "fixed to the world",
        ),
        # a constraint on a step that does not exist
        (lambda p: p["goal"][0].update(at=9), "goal[0].at", "step 9 does not exist"),
        (lambda p: p["goal"][0].update(at="lift"), "goal[0].at", "no step or group 'lift'"),
        (lambda p: p["goal"][0].update(target="hammer"), "goal[0].target", "is not a container"),
        # a non-unit quaternion, NaN, absurd sizes
        (
            lambda p: p["scene"]["objects"][0].update(pose=[0.45, 0.25, 0.64, 0, 0, 0, 2]),
            "scene.objects[0].pose",
            "unit quaternion",
        ),
        (
            lambda p: p["scene"]["objects"][0].update(pose=[float("nan"), 0.25, 0.64, 0, 0, 0, 1]),
            "scene.objects[0].pose[0]",
            "finite",
        ),
        (
            lambda p: p["scene"]["objects"][0].update(pose=[1e6, 0.25, 0.64, 0, 0, 0, 1]),
            "scene.objects[0].pose",
            "more than 10.0 m",
        ),
        (
            lambda p: p["scene"]["robots"][0].update(base=[0, 50, 0]),
            "scene.robots[0].base[1]",
            "less than or equal to 10",
        ),
        (
            lambda p: p["options"].update(candidates=100000),
            "options.candidates",
            "less than or equal to 256",
        ),
        (lambda p: p.update(skeleton=p["skeleton"] * 20), "skeleton", "at most 64"),
        (
            lambda p: p["scene"]["objects"][0].update(name="x" * 500),
            "scene.objects[0].name",
            "at most 64",
        ),
        (
            lambda p: p["scene"]["objects"][0].update(kind="anvil"),
            "scene.objects[0].kind",
            "unknown object kind 'anvil'",
        ),
        (
            lambda p: p["skeleton"][0].update(colour="red"),
            "skeleton[0].colour",
            "Extra inputs are not permitted",
        ),
        (lambda p: p["options"].update(top_k=20), "options", "top_k (20) exceeds candidates (10)"),
    ],
)
def test_invalid_plans_name_the_place_and_the_reason(mutate: Any, loc: str, fragment: str) -> None:
    plan = example()
    mutate(plan)
    found = errors_of(plan)
    assert any(l == loc and fragment in m for l, m in found), found  # noqa: E741


def test_every_error_is_reported_not_just_the_first() -> None:
    plan = example()
    plan["skeleton"][0]["skill"] = "teleport"
    plan["skeleton"][3]["target"] = "shelf"
    plan["goal"][0]["at"] = 12
    locs = {loc for loc, _ in errors_of(plan)}
    assert {"skeleton[0].skill", "skeleton[3].target", "goal[0].at"} <= locs


def test_load_plan_reports_json_syntax_with_line(tmp_path: Any) -> None:
    bad = tmp_path / "plan.json"
    bad.write_text('{"scene": {\n  "robots": [,]\n}}')
    with pytest.raises(PlanError) as info:
        load_plan(bad)
    assert info.value.issues[0].loc.endswith(":2:14")


# ---------------------------------------------------------------- property: valid skeletons compile

ROBOTS = ["left", "right"]
OBJECTS = {"hammer": "hammer", "cube": "cube", "mug": "mug"}


@st.composite
def valid_skeletons(draw: st.DrawFn) -> dict[str, Any]:
    """Random symbolically feasible skeletons: a simulated holding state picks legal next steps."""
    holding: dict[str, str | None] = dict.fromkeys(ROBOTS)
    steps: list[dict[str, Any]] = []
    for _ in range(draw(st.integers(1, 14))):
        robot = draw(st.sampled_from(ROBOTS))
        other = "right" if robot == "left" else "left"
        held = holding[robot]
        options = []
        if held is None:
            free_objects = [o for o in OBJECTS if o not in holding.values()]
            options += [("pick", o) for o in free_objects]
            if holding[other] is not None:
                options.append(("regrasp", holding[other]))
            options.append(("move", None))
        else:
            options += [("move", held), ("place", held)]
        skill, obj = draw(st.sampled_from(options))
        step: dict[str, Any] = {"skill": skill, "robot": robot}
        if obj is not None:
            step["object"] = obj
        if skill == "place":
            step["target"] = "box"
            holding[robot] = None
        elif skill == "pick":
            holding[robot] = obj
        elif skill == "regrasp":
            step["from"] = other
            holding[robot], holding[other] = obj, None
        steps.append(step)
    objects = [
        {"name": n, "kind": k, "pose": [0.4, 0.1 * i, 0.64, 0, 0, 0, 1]}
        for i, (n, k) in enumerate(OBJECTS.items())
    ]
    objects.append({"name": "box", "kind": "box", "pose": [0.5, -0.4, 0.625, 0, 0, 0, 1], "fixed": True})
    return {
        "scene": {
            "robots": [{"name": r, "base": [0, 0.35 if r == "left" else -0.35, 0.625]} for r in ROBOTS],
            "objects": objects,
        },
        "skeleton": steps,
        "goal": [
            {
                "type": "near",
                "object": "hammer",
                "target": "box",
                "distance": 0.5,
                "at": len(steps) - 1,
            }
        ],
    }


@given(valid_skeletons())
def test_generated_valid_skeletons_compile(plan: dict[str, Any]) -> None:
    graph = compile_plan(json.loads(json.dumps(plan)))
    assert len(graph.temporal) == len(plan["skeleton"])
    # Every effect node is new and every pre node existed before its step.
    seen: set[int] = {n.id for n in graph.known}
    for factor in graph.temporal:
        pre = {t.node for t in factor.tokens if t.phase == "pre"}
        effect = {t.node for t in factor.tokens if t.phase == "effect"}
        assert pre <= seen
        assert not effect & seen
        seen |= {n for n in effect if n is not None}


def test_mutating_a_compiled_plan_input_does_not_change_it() -> None:
    plan = example()
    graph = compile_plan(copy.deepcopy(plan))
    plan["skeleton"].clear()
    assert len(graph.temporal) == 4


def test_a_yaw_goal_aims_inside_its_bound() -> None:
    """tolerance_deg is what the simulator checks; the energy's sigma is a third of it, so a
    heading right at the bound costs 3^2 / 2 and the factor's mass lies 99.7 % inside."""
    import math

    import torch

    from gfc.constraints import scaled_residual

    plan = {
        "scene": {
            "robots": [{"name": "left", "base": [0, 0.35, 0.625]}],
            "objects": [{"name": "pot", "kind": "pot", "pose": [0.5, 0, 0.625, 0, 0, 0, 1]}],
        },
        "skeleton": [
            {"skill": "pick", "robot": "left", "object": "pot"},
            {"skill": "move", "robot": "left", "object": "pot"},
        ],
        "goal": [{"type": "yaw", "object": "pot", "yaw_deg": 30, "tolerance_deg": 6}],
    }
    (goal,) = [f for f in compile_plan(plan).spatial if f.type == "yaw"]
    assert goal.params["tolerance"] == pytest.approx(math.radians(2.0))
    at_bound = math.radians(36.0)
    pose9 = torch.tensor(
        [
            [
                0.5,
                0.0,
                0.7,
                math.cos(at_bound),
                math.sin(at_bound),
                0.0,
                -math.sin(at_bound),
                math.cos(at_bound),
                0.0,
            ]
        ]
    )
    residual = scaled_residual("yaw", [pose9], goal.params)
    assert residual.abs().item() == pytest.approx(3.0, rel=1e-4)


def test_a_pour_asks_both_containers_upright_before_it() -> None:
    """The pour's precondition enters as implied upright factors on the versions of the mug and
    the cup that the pour reads (after the meeting moves), whatever the plan states."""
    from gfc.skills.signatures import POUR_UPRIGHT_DEG

    graph = compile_plan(sample_task("pour_cup", 0).plan)
    upright = [f for f in graph.spatial if f.type == "upright"]
    assert [f.source for f in upright] == ["implied", "implied"]
    assert {graph.nodes[f.nodes[0]].entity for f in upright} == {"mug", "cup"}
    meet_moves = [t for t in graph.temporal if t.skill == "move"]
    written = {tok.node for t in meet_moves for tok in t.tokens if tok.phase == "effect"}
    assert all(f.nodes[0] in written for f in upright)
    import math

    assert upright[0].params["tolerance"] == pytest.approx(math.sin(math.radians(POUR_UPRIGHT_DEG)) / 3)
    no_pour = sample_task("pour_cup", 0).plan.model_dump(by_alias=True)
    no_pour["skeleton"] = no_pour["skeleton"][:-1]
    assert not [f for f in compile_plan(no_pour).spatial if f.type == "upright"]


def test_a_pour_keeps_the_holding_hand_out_of_the_way() -> None:
    """The pour adds ``palm_clear`` over the mug and cup versions it reads and the action of
    the mug's grasp (the pick by the arm that pours), with the two rims' frames."""
    graph = compile_plan(sample_task("pour_cup", 0).plan)
    (palm,) = [f for f in graph.spatial if f.type == "palm_clear"]
    upright = {f.nodes[0] for f in graph.spatial if f.type == "upright"}
    assert [graph.nodes[n].entity for n in palm.nodes] == ["mug", "cup"]
    assert set(palm.nodes) == upright
    (action,) = palm.actions
    step = graph.actions[action].step
    pick = sample_task("pour_cup", 0).plan.skeleton[step]
    pour = sample_task("pour_cup", 0).plan.skeleton[-1]
    assert (pick.skill, pick.object, pick.robot) == ("pick", "mug", pour.robot)
    assert palm.params["source_frame"] == list(OBJECT_KINDS["mug"].frame("rim"))


def test_a_pour_is_a_factor_over_its_pre_nodes_and_a_strike_stays_terminal() -> None:
    """A pour's learned pre-state model (docs/adr/0006) enters as a temporal factor over exactly
    the nodes the pour reads (the pourer, the mug and the cup after the meeting), with no action
    and no effect; a strike has no model and is listed as terminal."""

    graph = compile_plan(sample_task("pour_cup", 0).plan)
    pour = next(f for f in graph.temporal if f.skill == "pour")
    assert pour.model == "pour.mug.cup" and pour.step == 4 and pour.robot == "left"
    assert [(t.role, t.phase) for t in pour.tokens] == [
        ("robot", "pre"),
        ("object", "pre"),
        ("target", "pre"),
    ]
    meet = [f for f in graph.temporal if f.skill == "move"]
    written = {graph.nodes[t.node].entity: t.node for f in meet for t in f.tokens if t.phase == "effect"}
    read = {graph.nodes[t.node].entity: t.node for t in pour.tokens if t.node is not None}
    assert read == {e: written[e] for e in ("left", "mug", "cup")}
    assert not graph.terminal
    nail = compile_plan(sample_task("hammer_nail", 0).plan)
    assert [skill for _, skill in nail.terminal] == ["strike"]
    assert all(f.skill != "strike" for f in nail.temporal)


def test_the_compiler_keeps_every_hand_in_reach_and_a_handovers_grasps_apart() -> None:
    """Physics the compiler implies whatever the plan states: each sampled hand within
    PANDA_REACH of its arm's shoulder, and at each hand-over the receiver's grasp action clear of
    the grasp by which the giver holds the object (its pick, or the regrasp that gave it to it)."""
    from gfc.kinds import PANDA_REACH, PANDA_SHOULDER_Z

    plan = example()
    plan["skeleton"] = [
        {"skill": "pick", "robot": "left", "object": "hammer"},
        {"skill": "regrasp", "robot": "right", "object": "hammer", "from": "left"},
        {"skill": "regrasp", "robot": "left", "object": "hammer", "from": "right"},
    ]
    plan["goal"] = []
    graph = compile_plan(plan)
    reach = [f for f in graph.spatial if f.type == "reach"]
    assert sorted(graph.nodes[f.nodes[0]].label for f in reach) == sorted(
        n.label for n in graph.free if n.entity_type == "robot"
    )
    for f in reach:
        base = next(r.base for r in parse_plan(plan).scene.robots if r.name == graph.nodes[f.nodes[0]].entity)
        assert f.params["shoulder"] == pytest.approx([base[0], base[1], base[2] + PANDA_SHOULDER_Z])
        assert f.params["reach"] == PANDA_REACH
    action_of_step = {a.step: a.id for a in graph.actions}
    apart = [f.actions for f in graph.spatial if f.type == "grasps_apart"]
    assert apart == [(action_of_step[0], action_of_step[1]), (action_of_step[1], action_of_step[2])]


def test_a_stroke_ties_its_targets_effect_to_its_action() -> None:
    """Each push and pull with the hook gets an implied ``stroke`` factor over the target before
    and after it and the stroke's action, with the hook's geometry and the direction of travel."""
    from gfc.kinds import HOOK_TIP_BAR_HALF_X

    graph = compile_plan(sample_task("hook_reach_t3", 0).plan)
    strokes = [f for f in graph.spatial if f.type == "stroke"]
    pulls = [i for i, s in enumerate(sample_task("hook_reach_t3", 0).plan.skeleton) if s.skill == "pull"]
    action_of_step = {a.step: a.id for a in graph.actions}
    assert [f.actions for f in strokes] == [(action_of_step[i],) for i in pulls]
    for f in strokes:
        before, after = (graph.nodes[n] for n in f.nodes)
        assert before.entity == after.entity and after.version == before.version + 1
        assert f.source == "implied" and f.params["sign"] == -1.0
        assert f.params["bar_half_x"] == HOOK_TIP_BAR_HALF_X
    push = compile_plan(sample_task("rearrangement_push_t1", 0).plan)
    assert [f.params["sign"] for f in push.spatial if f.type == "stroke"] == [1.0]


def test_apart_needs_two_objects_and_reads_their_footprints() -> None:
    plan = copy.deepcopy(sample_task("constrained_packing_t1", 0).plan.to_json_dict())
    graph = compile_plan(plan)
    apart = [f for f in graph.spatial if f.type == "apart" and f.source == "constraints"]
    assert len(apart) == 6  # every pair of 4 blocks
    assert apart[0].params["object_half_extents"] == [0.025, 0.025, 0.025]
    plan["constraints"].append({"type": "apart", "object": "block_0", "target": "right"})
    with pytest.raises(
        PlanError, match=r"constraints\[6\]\.target: 'right' is a robot; apart is between objects"
    ):
        compile_plan(plan)


def test_placements_on_one_target_keep_apart_and_inside_its_walls() -> None:
    """Objects placed on one target and left there: each later place action keeps clear of
    theirs, and so do the fingers placing it, of theirs and of the walls (``fingers_clear``, with its grasp), each block
    is grasped near the middle of the pads (``grasp_centred``, on the pick), and a block
    placed into a box is released inside its walls (factors on the place actions, poses in the
    target's frame). A hammer, too long to fit the box at any yaw,
    gets no ``placed_inside``; an object picked up again stops counting."""
    graph = compile_plan(sample_task("constrained_packing_t1", 0).plan)
    places = [a.id for a in graph.actions if graph.temporal[a.step].skill == "place"]
    picks = [a.id for a in graph.actions if graph.temporal[a.step].skill == "pick"]
    implied = [(f.type, f.actions) for f in graph.spatial if f.source == "implied" and f.type != "reach"]
    expected = []
    for k, (pick, place) in enumerate(zip(picks, places, strict=True)):
        expected += [("grasp_centred", (pick,)), ("placed_inside", (place,)), ("placed_reach", (place,))]
        expected += [("apart", (earlier, place)) for earlier in places[:k]]
        expected += [("fingers_clear", (place, pick, *places[:k]))]
    assert implied == expected
    assert not [
        f for f in compile_plan(sample_task("hammer_place", 0).plan).spatial if f.type == "placed_inside"
    ]
    plan = sample_task("constrained_packing_t1", 0).plan.to_json_dict()
    plan["skeleton"][2:2] = [
        {"skill": "pick", "robot": "right", "object": "block_0"},
        {"skill": "place", "robot": "right", "object": "block_0", "target": "box"},
    ]
    graph = compile_plan(plan)
    place_actions = [a.id for a in graph.actions if graph.temporal[a.step].skill == "place"]
    pairs = [f.actions for f in graph.spatial if f.type == "apart" and f.source == "implied"]
    assert (place_actions[0], place_actions[1]) not in pairs  # block_0 was picked up again
    assert (place_actions[1], place_actions[2]) in pairs


@pytest.mark.parametrize(
    "task",
    ["constrained_packing_t3", "hook_reach_t3", "rearrangement_push_t3", "hammer_nail_v2", "hammer_place"],
)
def test_the_reference_actions_satisfy_the_implied_factors_on_actions(task: str) -> None:
    """The hand-written solutions (which succeed in the simulator) are inside every implied
    factor that reads actions (and known nodes only): the compiler never asks against a
    working plan."""
    import torch

    from gfc.constraints import scaled_residual

    instance = sample_task(task, 0)
    graph = compile_plan(instance.plan)
    value = {a.id: instance.reference_actions[a.step] for a in graph.actions}
    checked = 0
    for f in graph.spatial:
        if not f.actions or any(not graph.nodes[n].known for n in f.nodes):
            continue
        known = [graph.nodes[n].value for n in f.nodes]
        inputs = [torch.tensor(v[:9], dtype=torch.float64).unsqueeze(0) for v in known if v is not None]
        inputs += [torch.tensor(value[a], dtype=torch.float64).unsqueeze(0) for a in f.actions]
        assert float(scaled_residual(f.type, inputs, f.params).abs().max()) <= 1.0, (f.type, f.actions)
        checked += 1
    assert checked


def test_a_placement_by_the_rack_is_released_clear_of_it_and_within_reach() -> None:
    graph = compile_plan(sample_task("rearrangement_push_t1", 0).plan)
    place = next(a.id for a in graph.actions if graph.temporal[a.step].skill == "place")
    by_type = {f.type: f for f in graph.spatial if f.source == "implied" and f.actions == (place,)}
    assert set(by_type) == {"released_clear", "placed_reach", "relative_pose"}
    assert graph.nodes[by_type["placed_reach"].nodes[0]].entity == "rack"
    assert by_type["released_clear"].params["target_half_extents"] == [0.05, 0.25, 0.06]


def test_a_stroke_after_a_placement_starts_where_the_place_action_puts_the_object() -> None:
    """The push plans from the block's node after its placement; a ``relative_pose`` link ties
    that node to the place action in the rack's frame (the place model alone left it 11-27 cm
    off). Without a stroke after it (packing) a placement gets no such link, and with
    ``options.kinematics`` on it comes once, from the kinematic links."""
    plan = sample_task("rearrangement_push_t2", 0).plan
    graph = compile_plan(plan)
    place = next(a for a in graph.actions if graph.temporal[a.step].skill == "place" and a.step == 3)
    (link,) = [f for f in graph.spatial if f.type == "relative_pose"]
    assert link.source == "implied" and link.actions == (place.id,)
    rack, block = (graph.nodes[n] for n in link.nodes)
    assert rack.entity == "rack" and block.entity == "block" and block.written_by == (3,)
    (stroke,) = [f for f in graph.spatial if f.type == "stroke"]
    assert stroke.nodes[0] == block.id
    packing = compile_plan(sample_task("constrained_packing_t2", 0).plan)
    assert not [f for f in packing.spatial if f.type == "relative_pose"]
    data = plan.to_json_dict()
    data["options"]["kinematics"] = True
    linked = compile_plan(data)
    assert len([f for f in linked.spatial if f.type == "relative_pose" and f.actions == (place.id,)]) == 1


def test_a_goal_tolerance_is_a_bound_the_energy_keeps_well_inside() -> None:
    """An ``aligned`` goal's tolerance is what the simulator checks; its factor's sigma is a third
    of it (as a yaw goal's). A constraint's tolerance is its sigma."""
    graph = compile_plan(sample_task("rearrangement_push_t1", 0).plan)
    (goal,) = [f for f in graph.spatial if f.type == "aligned"]
    assert goal.source == "goal" and goal.params["tolerance"] == pytest.approx(0.04 / 3)
    nail = compile_plan(sample_task("hammer_nail", 0).plan)
    tolerances = sorted((f.source, f.params["tolerance"]) for f in nail.spatial if f.type == "aligned")
    assert tolerances == [("constraints", pytest.approx(0.02 / 3)), ("goal", pytest.approx(0.02 / 3))]


def test_an_object_too_big_for_a_container_is_not_kept_apart_from_what_lands_on_it() -> None:
    """The example puts the lid (32 x 22 cm) "in" a 30 x 20 cm box, where it rests on the rim,
    and the cube after it: the cube is released inside the box's walls (it fits), the lid gets
    no such factor, and nothing keeps the two apart (the cube lands on the lid)."""
    graph = compile_plan(load_example("hammer_nail"))
    step_of = {a.id: a.step for a in graph.actions}
    skeleton = load_example("hammer_nail")["skeleton"]
    inside = [skeleton[step_of[f.actions[0]]]["object"] for f in graph.spatial if f.type == "placed_inside"]
    assert inside == ["cube"]
    assert not [f for f in graph.spatial if f.type == "apart"]
