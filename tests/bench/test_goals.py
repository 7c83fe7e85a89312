"""The verdict table: each task's top-1 against the paper, our goal and the best baseline."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gfc.bench.goals import BARS, verdict_markdown, verdicts, wilson_interval
from gfc.tasks import ALL_TASKS


def _row(top1: float) -> dict[str, object]:
    return {"top1": top1, "any5": top1, "trials": 10, "plan_seconds_median": 0.1, "failures": {}}


def test_every_bar_names_a_registered_task() -> None:
    assert set(BARS) <= set(ALL_TASKS)


def test_verdicts_compare_with_the_paper_the_goal_and_the_best_baseline() -> None:
    summary = {
        "tasks": {
            "hammer_place": {"gfc": _row(0.7), "random": _row(0.0), "linear_chain": _row(0.75)},
            "pour_cup": {"gfc": _row(0.9), "random": _row(0.1), "reference": _row(1.0)},
            "hammer_place_interleaved": {"gfc": _row(0.5)},  # no bar: not in the verdicts
        }
    }
    rows = {r["task"]: r for r in verdicts(summary)}
    assert set(rows) == {"hammer_place", "pour_cup"}
    place = rows["hammer_place"]
    assert place["beats_paper"] and not place["meets_goal"]  # 0.70 vs 0.63 and 0.90
    assert place["best_baseline"] == {"method": "linear_chain", "top1": 0.75}
    assert not place["above_baselines"]
    pour = rows["pour_cup"]
    assert pour["meets_goal"] and pour["above_baselines"]  # the reference oracle is no baseline
    assert pour["best_baseline"] == {"method": "random", "top1": 0.1}
    text = "\n".join(verdict_markdown(summary))
    assert "| hammer_place | 70% | 40-89% | 10 | 63% | 90% | yes | MISSED | linear_chain 75% | NO |" in text


def test_wilson_interval_matches_known_values() -> None:
    assert wilson_interval(50, 100) == pytest.approx((0.4038, 0.5962), abs=1e-4)
    assert wilson_interval(0, 20) == pytest.approx((0.0, 0.1611), abs=1e-4)
    assert wilson_interval(7, 10) == pytest.approx((0.3968, 0.8922), abs=1e-4)


@given(n=st.integers(1, 500), data=st.data())
def test_wilson_interval_holds_the_observed_rate_inside_unit_bounds(n: int, data: st.DataObject) -> None:
    k = data.draw(st.integers(0, n))
    low, high = wilson_interval(k, n)
    assert 0.0 <= low <= k / n <= high <= 1.0
    wider_low, wider_high = wilson_interval(4 * k, 4 * n)
    assert wider_high - wider_low <= high - low  # four times the trials: a narrower interval
