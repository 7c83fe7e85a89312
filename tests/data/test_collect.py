"""``gfc collect`` for real: simulated picks become dataset rows; an interrupted run resumes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gfc.data.collect import Attempt, Prior, prior_source, run_attempt, world_state
from gfc.data.dataset import load_dataset, read_index
from gfc.data.runner import model_layout
from gfc.data.scenarios import SCENARIOS


def test_the_prior_mixes_heuristic_and_uniform_actions() -> None:
    rng = np.random.default_rng(0)
    scenario = SCENARIOS["pick.cube"](rng)
    near = prior_source(Prior(uniform_share=0.0))
    wide = prior_source(Prior(uniform_share=1.0))
    state = world_state({}, {})
    heuristic = np.array([near(scenario, state, rng)[0] for _ in range(200)])
    uniform = np.array([wide(scenario, state, rng)[0] for _ in range(200)])
    assert np.abs(heuristic[:, :2]).max() < 0.04  # a top-down grasp near the cube's centre
    assert np.abs(uniform[:, :2]).max() > 0.03  # uniform draws reach the whole box around it
    downward = np.cross(heuristic[:, 3:6], heuristic[:, 6:9])[:, 2]
    assert (downward < -0.99).all()
    assert (np.cross(uniform[:, 3:6], uniform[:, 6:9])[:, 2] > 0).any()  # any rotation


@pytest.mark.slow
def test_an_attempt_with_a_setup_reports_rows_of_the_target_step_only() -> None:
    result = run_attempt(Attempt("place.hammer.box", seed=1, prior=Prior(uniform_share=0.0)))
    assert result["status"] in {"success", "failure", "setup"}
    results = [result] + [
        run_attempt(Attempt("place.hammer.box", seed=s, prior=Prior(uniform_share=0.0))) for s in range(2, 5)
    ]
    rows = [row for r in results if r["status"] == "success" for row in r["rows"]]
    assert rows, [r.get("reason") for r in results]
    layout = model_layout("place.hammer.box")
    for row in rows:
        assert len(row) == layout.total_dim
        pre_gripper, effect_gripper = row[9], row[10 + 9 + 9 + 9 + 9]
        assert pre_gripper < 0.07  # before the place the hand held the hammer (set-up pick)
        assert effect_gripper > 0.07  # and let go of it after


def collect(out: Path, n: int) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "gfc.cli", "collect", "pick", "--object", "cube", "-n", str(n),
         "--shard-size", "3", "--processes", "1", "--out", str(out)],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip


@pytest.mark.slow
def test_collect_picks_and_resume(tmp_path: Path) -> None:
    out = tmp_path / "pick.cube"
    first = collect(out, 6)
    assert first.returncode == 0, first.stdout + first.stderr
    assert [s.attempts for s in read_index(out).shards] == [3, 3]
    again = collect(out, 9)  # as if the first run had been asked for 9 and interrupted after 6
    assert again.returncode == 0, again.stdout + again.stderr
    index = read_index(out)
    assert [s.attempts for s in index.shards] == [3, 3, 3]
    assert sum(s.rows + sum(s.failures.values()) for s in index.shards) == 9  # every attempt accounted for
    data, _ = load_dataset(out)
    assert data.shape[0] == index.rows >= 1, "no pick out of 9 succeeded"
    rows = data.double().numpy()
    lift = rows[:, 38 + 2] - rows[:, 10 + 2]  # effect object z - pre object z (base frame)
    assert (lift > 0.05).all()  # a successful pick lifts the cube
    assert (rows[:, 28 + 9] < 0.075).all()  # and the fingers closed on it (0.08 is open)
    bad = subprocess.run(
        [sys.executable, "-m", "gfc.cli", "collect", "pick", "--object", "box", "-n", "1", "--out", str(tmp_path / "x")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert bad.returncode == 2 and "no scene sampler" in bad.stdout
