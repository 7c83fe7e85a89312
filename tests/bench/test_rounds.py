"""Sampling rounds (``PlanSettings.rounds``): a method whose draw has no candidate that passes
the kinematic screen draws again with a fresh seed, up to the rounds allowed, every method alike.

The screen is replaced by a stand-in that passes the candidates a test marks, so these check the
bookkeeping (which draw, in which order, how many rounds); the screen itself has its own tests."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gfc.bench import methods
from gfc.bench.methods import (
    MethodPlan,
    PlanSettings,
    _random,
    batch_seed,
    make_method,
    screened,
)
from gfc.bench.uniform import random_actions
from gfc.geometry import FloatArray
from gfc.plan.compiler import compile_plan
from gfc.plan.schema import PlanRequest
from gfc.planner.library import random_library
from gfc.sim.screen import Verdict
from gfc.tasks import sample_task
from gfc.tasks.base import TaskInstance

TASK = "pot_reorientation"

PASS = 1.0  # a candidate whose first action starts with this passes the stand-in screen


def fake_screen(
    plan: PlanRequest, candidates: Sequence[Sequence[FloatArray | None]], keep: int, seed: int = 0
) -> tuple[list[int], list[Verdict | None]]:
    verdicts: list[Verdict | None] = [Verdict(bool(c[0] is not None and c[0][0] == PASS)) for c in candidates]
    passed = [k for k, v in enumerate(verdicts) if v is not None and v.feasible]
    return passed + [k for k in range(len(candidates)) if k not in passed], verdicts


@pytest.fixture(autouse=True)
def stand_in_screen(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(methods, "screen_order", fake_screen)


class Draws:
    """A method whose draw ``batch`` is ``plans[batch]``: per candidate, 1 (passes) or 0."""

    def __init__(self, plans: list[list[int]]) -> None:
        self.plans = plans
        self.batches: list[int] = []

    def __call__(self, instance: TaskInstance, settings: PlanSettings, batch: int = 0) -> MethodPlan:
        self.batches.append(batch)
        candidates = [[np.array([float(mark), batch, k])] for k, mark in enumerate(self.plans[batch])]
        return MethodPlan(list(candidates), 1.0)


def ids(plan: MethodPlan) -> list[tuple[int, int]]:
    """(batch, index in its draw) of each ranked candidate."""
    out = []
    for c in plan.candidates:
        first = c[0]
        assert first is not None
        out.append((int(first[1]), int(first[2])))
    return out


INSTANCE = sample_task(TASK, 0)


def test_one_round_draws_once_even_when_nothing_passes() -> None:
    draws = Draws([[0, 0, 0], [1, 1, 1]])
    plan = screened(draws)(INSTANCE, PlanSettings(candidates=3))
    assert draws.batches == [0]
    assert (plan.passed_screen, plan.rounds) == (0, 1)
    assert ids(plan) == [(0, 0), (0, 1), (0, 2)]  # the method's own order


def test_a_draw_that_passes_ends_the_rounds() -> None:
    draws = Draws([[0, 1, 0], [1, 1, 1]])
    plan = screened(draws)(INSTANCE, PlanSettings(candidates=3, rounds=4))
    assert draws.batches == [0]
    assert (plan.passed_screen, plan.rounds) == (1, 1)
    assert ids(plan) == [(0, 1), (0, 0), (0, 2)]


def test_a_later_draw_that_passes_goes_first_then_its_rest_then_the_earlier_draws() -> None:
    draws = Draws([[0, 0], [0, 0], [0, 1], [1, 1]])
    plan = screened(draws)(INSTANCE, PlanSettings(candidates=2, rounds=4))
    assert draws.batches == [0, 1, 2]
    assert (plan.passed_screen, plan.rounds, plan.seconds) == (1, 3, pytest.approx(3.0, abs=0.5))
    assert ids(plan) == [(2, 1), (2, 0), (0, 0), (0, 1), (1, 0), (1, 1)]


def test_when_no_draw_passes_the_first_draw_leads_and_every_round_is_spent() -> None:
    draws = Draws([[0, 0], [0, 0], [0, 0]])
    plan = screened(draws)(INSTANCE, PlanSettings(candidates=2, rounds=3))
    assert draws.batches == [0, 1, 2]
    assert (plan.passed_screen, plan.rounds) == (0, 3)
    assert ids(plan)[:2] == [(0, 0), (0, 1)]


def test_without_the_screen_there_is_one_draw() -> None:
    draws = Draws([[0, 0], [1, 1]])
    plan = screened(draws)(INSTANCE, PlanSettings(candidates=2, rounds=3, screen=False))
    assert draws.batches == [0] and plan.passed_screen is None


@given(seed=st.integers(0, 2**63 - 1), batch=st.integers(1, 1000))
def test_batch_seeds_differ_where_torch_looks_and_batch_zero_is_the_plans_own(seed: int, batch: int) -> None:
    assert batch_seed(seed, 0) == seed
    later = batch_seed(seed, batch)
    assert 0 <= later < 2**32  # torch's CPU generator keeps the low 32 bits of a seed
    assert later != batch_seed(seed, batch + 1)


def test_the_learned_methods_draw_other_candidates_in_another_batch() -> None:
    instance = sample_task(TASK, 1)
    library = random_library(compile_plan(instance.plan))
    settings = PlanSettings(candidates=4, steps=3, screen=False)
    method = make_method("gfc", library)
    first, again, other = (method(instance, settings, b) for b in (0, 0, 1))

    def flat(p: MethodPlan) -> np.ndarray:
        return np.concatenate([a for c in p.candidates for a in c if a is not None])

    assert np.array_equal(flat(first), flat(again))
    assert not np.allclose(flat(first), flat(other))


def test_random_keeps_its_stream_for_batch_zero_and_draws_anew_after() -> None:
    settings = PlanSettings(candidates=3, screen=False)
    zero, one = _random(INSTANCE, settings, 0), _random(INSTANCE, settings, 1)
    rng = np.random.default_rng([INSTANCE.seed, 7])  # the stream of logs before batches existed
    expected = random_actions(INSTANCE.plan, rng)
    assert all(
        (a is None and b is None) or (a is not None and b is not None and np.array_equal(a, b))
        for a, b in zip(zero.candidates[0], expected, strict=True)
    )
    assert not all(
        a is None or b is None or np.array_equal(a, b)
        for a, b in zip(zero.candidates[0], one.candidates[0], strict=True)
    )
