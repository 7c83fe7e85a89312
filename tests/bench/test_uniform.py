"""The random baseline's uniform samplers: shapes, orthonormal rotations, bounds."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gfc.bench.uniform import (
    ActionBox,
    action_box,
    random_actions,
    random_rotation,
    uniform_action,
    uniform_box,
    uniform_pose9,
)
from gfc.geometry import pose9_to_matrix
from gfc.skills.signatures import skill_spec
from gfc.tasks import ALL_TASKS, sample_task

seeds = st.integers(min_value=0, max_value=2**32 - 1)
coordinate = st.floats(min_value=-2.0, max_value=2.0, allow_nan=False)


@st.composite
def boxes(draw: st.DrawFn, dim: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    low = tuple(draw(coordinate) for _ in range(dim))
    high = tuple(lo + draw(st.floats(min_value=0.0, max_value=1.0)) for lo in low)
    return low, high


def assert_rotation_columns(action: np.ndarray) -> None:
    c1, c2 = action[3:6], action[6:9]
    np.testing.assert_allclose([c1 @ c1, c2 @ c2, c1 @ c2], [1.0, 1.0, 0.0], atol=1e-9)


@given(seeds)
def test_random_rotation_is_a_proper_rotation(seed: int) -> None:
    r = random_rotation(np.random.default_rng(seed))
    assert r.shape == (3, 3)
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-9)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-9)


def test_random_rotations_are_uniform_in_the_mean() -> None:
    # Under the Haar measure E[R] = 0; 4000 draws put each entry's mean within ~0.01 of it, and
    # a sampler biased towards the identity (small angles) would miss that by far.
    rng = np.random.default_rng(0)
    mean = np.mean([random_rotation(rng) for _ in range(4000)], axis=0)
    assert np.abs(mean).max() < 0.05


@given(seeds, boxes(3))
def test_uniform_pose9_stays_in_its_box_with_orthonormal_columns(
    seed: int, box: tuple[tuple[float, ...], tuple[float, ...]]
) -> None:
    low, high = box
    action = uniform_pose9(np.random.default_rng(seed), low, high)
    assert action.shape == (9,)
    assert np.all(action[:3] >= np.asarray(low)) and np.all(action[:3] <= np.asarray(high))
    assert_rotation_columns(action)


@given(seeds, boxes(4))
def test_uniform_box_stays_in_its_box(seed: int, box: tuple[tuple[float, ...], tuple[float, ...]]) -> None:
    low, high = box
    action = uniform_box(np.random.default_rng(seed), low, high)
    assert action.shape == (4,)
    assert np.all(action >= np.asarray(low)) and np.all(action <= np.asarray(high))


def test_a_box_must_be_a_box() -> None:
    with pytest.raises(ValueError, match="not a box"):
        ActionBox((0.0, 1.0), (1.0, 0.0), pose=False)
    assert uniform_action(np.random.default_rng(0), None) is None


@pytest.mark.parametrize("task", sorted(ALL_TASKS))
def test_random_actions_fit_each_skeleton(task: str) -> None:
    plan = sample_task(task, 0).plan
    actions = random_actions(plan, np.random.default_rng(1))
    assert len(actions) == len(plan.skeleton)
    for step, action in zip(plan.skeleton, actions, strict=True):
        dim = skill_spec(step.skill).action_dim
        if dim == 0:
            assert action is None
        else:
            assert action is not None and action.shape == (dim,)
            if dim == 9:
                assert_rotation_columns(action)


@pytest.mark.parametrize("task", sorted(ALL_TASKS))
def test_reference_actions_lie_in_the_random_baselines_boxes(task: str) -> None:
    """The boxes cover what solves the tasks, so the random baseline is not ruled out by design."""
    instance = sample_task(task, 2)
    for step, reference in zip(instance.plan.skeleton, instance.reference_actions, strict=True):
        box = action_box(instance.plan, step)
        if box is None:
            assert reference is None
            continue
        assert reference is not None
        position = pose9_to_matrix(reference)[:3, 3] if box.pose else reference
        assert np.all(position >= np.asarray(box.low)), (step, position, box)
        assert np.all(position <= np.asarray(box.high)), (step, position, box)
