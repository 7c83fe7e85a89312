"""The planner on compiled plans: frames, guidance, batching, ranking and output."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from gfc.diffusion.gaussian import GaussianBank, GaussianFactor
from gfc.examples import load_example
from gfc.geometry import matrix_to_pose9, pose7_to_matrix, pose9_frame_map, yaw_quat
from gfc.plan import compile_plan, parse_plan
from gfc.plan.graph import CompiledPlan, FactorToken, SpatialFactor, TemporalFactor
from gfc.planner.composed import ComposedScore
from gfc.planner.library import random_library
from gfc.planner.planner import plan_candidates
from gfc.planner.sampling import SamplingSettings, sample_graph
from tests.graphs import factor, layout_of, plan_of, random_gaussian, vector_node

PC = SamplingSettings(steps=60, sampler="euler", sigma_max=10.0, corrector_steps=3, corrector_snr=0.5)


def test_factor_in_a_robot_frame_is_mapped_to_the_world() -> None:
    """A skill model speaks in its robot's base frame; sampled world poses, mapped back into that
    frame, follow the model's distribution."""
    world_from_base = pose7_to_matrix([0.1, -0.35, 0.625, *yaw_quat(math.pi / 2)])
    node = vector_node(0, "cube", 1, 9)
    tf = TemporalFactor(
        0, "move", "m", "right", None,
        (FactorToken("action", "action", 1, action=0), FactorToken("object", "effect", 9, node=0)),
        tuple(tuple(float(v) for v in row) for row in world_from_base),
    )  # fmt: skip
    plan = plan_of([node], 1, [tf])
    model_mean = np.concatenate([[0.2], matrix_to_pose9(pose7_to_matrix([0.5, 0.1, 0.05, *yaw_quat(0.3)]))])
    cov = np.diag([0.01] + [0.0004] * 9)
    gf = GaussianFactor(layout_of(tf), torch.tensor(model_mean), torch.tensor(cov))
    composed = ComposedScore(plan, GaussianBank([gf]))
    z = sample_graph(composed, 2000, PC, torch.Generator().manual_seed(0)).double().numpy()
    a, b = pose9_frame_map(world_from_base)
    in_base = z[:, :9] @ a.T + b
    assert np.allclose(in_base.mean(0), model_mean[1:], atol=0.004)
    assert np.allclose(z[:, 9].mean(), 0.2, atol=0.01)
    # and in the world the cube sits where the base frame puts it
    assert np.allclose(z[:, :3].mean(0), (world_from_base @ [0.5, 0.1, 0.05, 1.0])[:3], atol=0.004)


def test_guidance_pulls_two_nodes_into_the_constraint() -> None:
    """Two independent factors; an energy ``a - b = d`` on their effect nodes couples them."""
    dims = {0: 2, 1: 2}
    nodes = [vector_node(0, "a", 1, 2), vector_node(1, "b", 1, 2)]
    fa = factor(0, "fa", [], 0, [0], dims)
    fb = factor(1, "fb", [], 1, [1], dims)
    offset = [0.8, -0.4]
    spatial = SpatialFactor(
        "offset",
        "constraint",
        0,
        (0, 1),
        {"offset": offset, "tolerance": 0.02, "weight": 1.0, "gain": 2.0},
    )
    factors = [random_gaussian(layout_of(fa), 11), random_gaussian(layout_of(fb), 12)]
    settings = SamplingSettings(steps=60, sigma_max=10.0)
    results = {}
    for name, extra in (("free", ()), ("guided", (spatial,))):
        plan = plan_of(nodes, 2, [fa, fb], extra)
        z = sample_graph(
            ComposedScore(plan, GaussianBank(factors)),
            500,
            settings,
            torch.Generator().manual_seed(1),
        )
        results[name] = (z[:, 0:2] - z[:, 2:4] - torch.tensor(offset)).norm(dim=1)
    assert float(results["free"].median()) > 0.5  # unconstrained: far from the offset
    assert float(results["guided"].quantile(0.9)) < 0.05  # guided: within a few tolerances


@pytest.fixture(scope="module")
def hammer_nail() -> tuple[CompiledPlan, object]:
    plan = compile_plan(load_example("hammer_nail"))
    return plan, random_library(plan)


def test_batched_and_per_factor_evaluation_agree(hammer_nail: tuple[CompiledPlan, object]) -> None:
    plan, library = hammer_nail
    bank = library.bank([f.model for f in plan.temporal])  # type: ignore[attr-defined]
    composed = ComposedScore(plan, bank.denoiser)
    g = torch.Generator().manual_seed(0)
    z = torch.randn(4, composed.layout.free_dim, generator=g)
    noise = torch.randn(4, composed.layout.known_dim, generator=g)
    with torch.no_grad():
        for sigma in (2.0, 0.3, 0.01):
            s = torch.tensor(sigma)
            batched = composed.model_score(z, s, noise)
            single = composed.model_score(z, s, noise, per_factor=True)
            assert torch.allclose(batched, single, rtol=1e-4, atol=1e-4 / sigma**2)


def test_compensation_touches_exactly_the_shared_nodes(
    hammer_nail: tuple[CompiledPlan, object],
) -> None:
    plan, _ = hammer_nail
    degree = plan.temporal_degree()
    library = random_library(plan)
    composed = ComposedScore(plan, library.bank([f.model for f in plan.temporal]).denoiser)
    queried = {plan.temporal[f].tokens[t].node for f, qs in enumerate(composed.queries) for t, _ in qs}
    shared = {n for n, d in degree.items() if d >= 2 and not plan.nodes[n].known}
    assert queried == shared
    weights = {w for qs in composed.queries for _, w in qs}
    assert weights == {-0.5}  # every shared node of this plan is shared by exactly two skills


def test_mean_compensation_counts_each_shared_node_once(hammer_nail: tuple[CompiledPlan, object]) -> None:
    """DESIGN.md's variant: the joint-score components of a shared node are averaged."""
    plan, library = hammer_nail
    bank = library.bank([f.model for f in plan.temporal]).denoiser  # type: ignore[attr-defined]
    composed = ComposedScore(plan, bank, compensation="mean")
    assert not composed.has_queries
    total = torch.zeros(composed.layout.free_dim + composed.layout.known_dim + 1)
    total.scatter_add_(0, composed.src.reshape(-1), composed.weight.reshape(-1))
    free = total[: composed.layout.free_dim]
    assert torch.allclose(free, torch.ones_like(free))  # every free dimension counted exactly once


def test_plan_candidates_are_ranked_and_complete(hammer_nail: tuple[CompiledPlan, object]) -> None:
    plan, library = hammer_nail
    request = parse_plan(load_example("hammer_nail"))
    options = request.options.model_copy(update={"candidates": 6, "top_k": 4, "steps": 8})
    result = plan_candidates(plan, library, options)  # type: ignore[arg-type]
    assert len(result.candidates) == 4
    costs = [c["cost"] for c in result.candidates]
    assert costs == sorted(costs)
    first = result.candidates[0]
    assert [s["step"] for s in first["steps"]] == list(range(11))
    pick = first["steps"][0]
    assert len(pick["action"]) == 9 and len(pick["action_pose"]) == 7
    rot = np.array(pick["action"][3:9]).reshape(2, 3)
    assert np.allclose(rot @ rot.T, np.eye(2), atol=1e-6)  # orthonormal columns: executable
    assert first["steps"][10]["action"] == []  # strike: precondition only
    assert set(first["nodes"]) == {n.label for n in plan.free}
    # The plan's aligned and far, and the compiler's reach, hand-over clearance and the physics of
    # placements (the cube released inside the spare box, every release within reach; the lid,
    # too big for that box, rests on its rim, so no apart between the two; the fingers placing
    # the cube clear of the box's walls); kinematic links are off by default.
    assert {r["type"] for r in first["residuals"]} == {
        "aligned",
        "far",
        "reach",
        "grasps_apart",
        "placed_inside",
        "placed_reach",
        "fingers_clear",
        "grasp_centred",
    }
    again = plan_candidates(plan, library, options)  # type: ignore[arg-type]
    assert again.candidates[0]["steps"] == first["steps"]  # same seed, same plan


@pytest.mark.slow
def test_aligned_constraint_is_met_with_guidance_on_real_poses(
    hammer_nail: tuple[CompiledPlan, object],
) -> None:
    """On the hammer-nail plan (random DiT skill models) guidance puts the hammer head over the
    nail top for most candidates; without the constraint almost none are."""
    plan, library = hammer_nail
    request = parse_plan(load_example("hammer_nail"))
    options = request.options.model_copy(update={"candidates": 20, "top_k": 20})
    guided = plan_candidates(plan, library, options)  # type: ignore[arg-type]
    unconstrained = compile_plan({**load_example("hammer_nail"), "constraints": []})
    free = plan_candidates(unconstrained, library, options)  # type: ignore[arg-type]
    aligned = next(i for i, f in enumerate(plan.spatial) if f.type == "aligned")
    ok = sum(c["residuals"][aligned]["satisfied"] for c in guided.candidates)
    assert ok >= 16, ok
    # Measure the same residual on the unconstrained samples through a guided ComposedScore.
    composed = ComposedScore(plan, library.bank([f.model for f in plan.temporal]).denoiser)  # type: ignore[attr-defined]
    head = [c["nodes"] for c in free.candidates]
    assert len(head) == 20
    z = torch.zeros(20, composed.layout.free_dim)
    for i, cand in enumerate(free.candidates):
        for node in plan.free:
            o = composed.layout.node_offset[node.id]
            z[i, o : o + 9] = torch.tensor(
                matrix_to_pose9(pose7_to_matrix(cand["nodes"][node.label]["pose"]))
            )
    residual = composed.spatial_residuals(z)[aligned].abs().amax(dim=1)
    assert int((residual <= 1.0).sum()) <= 4


def test_batched_requests_get_the_answers_they_would_get_alone() -> None:
    """Micro-batching: two different plans sampled together (one network call per step for both)
    give each the candidates it gets alone, up to floating-point rounding."""
    from gfc.planner.library import InMemoryLibrary
    from gfc.planner.planner import plan_many

    place = compile_plan(load_example("hammer_place"))
    nail = compile_plan(load_example("hammer_nail"))
    library = InMemoryLibrary({**random_library(place, seed=1).models, **random_library(nail, seed=2).models})
    base = parse_plan(load_example("hammer_place")).options
    options_a = base.model_copy(update={"candidates": 5, "top_k": 3, "steps": 6, "seed": 11})
    options_b = base.model_copy(update={"candidates": 8, "top_k": 2, "steps": 6, "seed": 12})
    together = plan_many([(place, options_a), (nail, options_b)], library)
    alone = [plan_candidates(place, library, options_a), plan_candidates(nail, library, options_b)]
    for batched, single in zip(together, alone, strict=True):
        assert [c["rank"] for c in batched.candidates] == [c["rank"] for c in single.candidates]
        for cb, cs in zip(batched.candidates, single.candidates, strict=True):
            for sb, ss in zip(cb["steps"], cs["steps"], strict=True):
                assert np.allclose(sb["action"], ss["action"], atol=1e-4)
        assert batched.timing["batched_with"] == 1.0
    with pytest.raises(ValueError, match="cannot share a batch"):
        plan_many([(place, options_a), (nail, options_b.model_copy(update={"steps": 7}))], library)


def test_a_moves_executed_action_is_its_held_objects_sampled_effect(
    hammer_nail: tuple[CompiledPlan, object],
) -> None:
    plan, library = hammer_nail
    request = parse_plan(load_example("hammer_nail"))
    options = request.options.model_copy(update={"candidates": 2, "top_k": 2, "steps": 4})
    candidate = plan_candidates(plan, library, options).candidates[0]  # type: ignore[arg-type]
    checked = 0
    for move in plan.temporal:
        if move.skill != "move":
            continue
        held = next(t for t in move.tokens if t.role == "object" and t.phase == "effect")
        assert held.node is not None
        world = np.asarray(candidate["nodes"][plan.nodes[held.node].label]["pose"])
        base = np.asarray(move.world_from_model)
        in_base = np.linalg.inv(base) @ pose7_to_matrix(world)
        step = next(s for s in candidate["steps"] if s["step"] == move.step)
        assert np.allclose(step["action"][:3], in_base[:3, 3], atol=1e-5)
        assert np.allclose(step["action"][3:6], in_base[:3, 0], atol=1e-4)
        checked += 1
    assert checked == 3  # hammer to the handover, nail up, hammer over the nail


def test_spatial_terms_read_actions_after_nodes() -> None:
    """A kinematic link on a place reads the cube's resting pose, the box's and the place action."""
    from gfc.planner.layout import VariableLayout
    from gfc.planner.spatial import SpatialTerms

    plan = compile_plan(
        {
            "scene": {
                "robots": [{"name": "left", "base": [0, 0.35, 0.625]}],
                "objects": [
                    {"name": "cube", "kind": "cube", "pose": [0.5, 0.3, 0.625, 0, 0, 0, 1]},
                    {"name": "box", "kind": "box", "pose": [0.5, 0.0, 0.625, *yaw_quat(0.4)], "fixed": True},
                ],
            },
            "skeleton": [
                {"skill": "pick", "robot": "left", "object": "cube"},
                {"skill": "place", "robot": "left", "object": "cube", "target": "box"},
            ],
            "options": {"kinematics": True},
        }
    )
    layout = VariableLayout.of(plan)
    spatial = SpatialTerms(plan, layout)
    (link_index,) = [i for i, (f, _) in enumerate(spatial.factors) if f.type == "relative_pose"]
    in_box = pose7_to_matrix([0.03, -0.02, 0.01, *yaw_quat(0.5)])
    box = pose7_to_matrix([0.5, 0.0, 0.625, *yaw_quat(0.4)])
    z = torch.zeros(1, layout.free_dim)
    cube = plan.node("cube@2").id
    action = next(a for a in plan.actions if a.step == 1).id
    z[0, layout.node_offset[cube] : layout.node_offset[cube] + 9] = torch.tensor(
        matrix_to_pose9(box @ in_box)
    )
    z[0, layout.action_offset[action] : layout.action_offset[action] + 9] = torch.tensor(
        matrix_to_pose9(in_box)
    )
    assert float(spatial.residuals(z)[link_index].abs().max()) < 1e-4
    z[0, layout.action_offset[action]] += 0.02  # the action says 2 cm further along the box's x
    assert float(spatial.residuals(z)[link_index].abs().max()) == pytest.approx(0.02 / 0.02, rel=1e-3)
