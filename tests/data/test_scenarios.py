"""Scenario samplers: valid plans, actions of the right shape, priors as broad as documented."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gfc.data.collect import node, pre_nodes, transition_row, world_state
from gfc.data.runner import model_layout
from gfc.data.scenarios import SCENARIOS, Scenario, grasp_proposal
from gfc.geometry import pose7_to_matrix, pose9_to_matrix
from gfc.plan.compiler import compile_plan
from gfc.skills.build import DEFAULT_MODELS
from gfc.skills.signatures import default_model_key, skill_spec

seeds = st.integers(min_value=0, max_value=2**32 - 1)


def fake_state(scenario: Scenario) -> dict[str, object]:
    """A state as the simulator reports it: every entity at its scene pose, hands at home-ish."""
    poses: dict[str, list[float]] = {o.name: list(o.pose) for o in scenario.plan.scene.objects}
    for r in scenario.plan.scene.robots:
        poses[r.name] = [r.base[0] + 0.3, r.base[1], r.base[2] + 0.5, 1.0, 0.0, 0.0, 0.0]
    return world_state(poses, {r.name: 0.08 for r in scenario.plan.scene.robots})


def test_every_default_model_has_a_scenario() -> None:
    assert set(DEFAULT_MODELS) <= set(SCENARIOS)


@pytest.mark.parametrize("model", sorted(SCENARIOS))
@given(seed=seeds)
def test_scenarios_compile_and_draw_executable_actions(model: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    scenario = SCENARIOS[model](rng)
    compile_plan(scenario.plan)  # the set-up plus target stage is a valid plan
    target = scenario.plan.skeleton[scenario.n_setup :]
    objects = {o.name: o.kind for o in scenario.plan.scene.objects}
    for step in target:  # every target step belongs to this model
        kind = objects.get(step.object) if step.object else None
        assert default_model_key(step.skill, kind, objects.get(step.target or "")) == model
    assert len(scenario.setup_actions) == scenario.n_setup
    state = fake_state(scenario)
    for draw in (scenario.propose, scenario.uniform):
        actions = draw(rng, state)  # type: ignore[arg-type]
        assert len(actions) == len(target)
        for step, action in zip(target, actions, strict=True):
            assert action.shape == (skill_spec(step.skill).action_dim,)
            assert np.all(np.isfinite(action))
            if action.shape == (9,):
                rotation = pose9_to_matrix(action)[:3, :3]
                assert np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-9)
            row = transition_row(scenario.plan, step, action, state, state)  # type: ignore[arg-type]
            assert row.shape == (model_layout(model).total_dim,)


def test_rows_are_in_the_acting_robots_base_frame() -> None:
    scenario = SCENARIOS["pick.cube"](np.random.default_rng(3))
    step = scenario.plan.skeleton[0]
    state = fake_state(scenario)
    robot = node(scenario.plan, step, step.robot, state)  # type: ignore[arg-type]
    assert np.allclose(robot[:3], [0.3, 0.0, 0.5]) and robot[9] == 0.08
    cube = scenario.plan.scene.objects[0]
    base = next(r.base for r in scenario.plan.scene.robots if r.name == step.robot)
    pre = pre_nodes(scenario.plan, step, state)  # type: ignore[arg-type]
    assert np.allclose(pre[10:13], np.asarray(cube.pose[:3]) - np.asarray(base))


def test_the_hammer_prior_covers_the_handle_with_the_hand_either_way_round() -> None:
    rng = np.random.default_rng(0)
    grasps = np.array([grasp_proposal("hammer", rng) for _ in range(400)])
    assert grasps[:, 0].min() < -0.09 and grasps[:, 0].max() > 0.03  # along the handle
    flips = np.sign(grasps[:, 3])  # the hand's x axis along +x or -x of the hammer
    assert 0.35 < (flips > 0).mean() < 0.65


def test_move_proposals_keep_the_held_object_upright() -> None:
    rng = np.random.default_rng(1)
    scenario = SCENARIOS["move.mug"](rng)
    state = fake_state(scenario)
    held = pose7_to_matrix(state["poses"]["obj"])  # type: ignore[index]
    for _ in range(50):
        (action,) = scenario.propose(rng, state)  # type: ignore[arg-type]
        target = pose9_to_matrix(action)  # where the mug goes (a move's action is the held object's pose)
        # The hand turns about the vertical (and tilts a few degrees): the mug's z axis stays put.
        assert target[:3, 2] @ held[:3, 2] > np.cos(np.radians(25))
