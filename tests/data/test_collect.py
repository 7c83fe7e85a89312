"""``gfc collect`` for real: simulated picks become dataset rows; an interrupted run resumes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gfc.data.collect import Prior, draw_action, pick_scenario
from gfc.data.dataset import load_dataset, read_index
from gfc.geometry import pose9_to_matrix


def test_prior_stays_near_the_proposal_except_for_its_uniform_share() -> None:
    rng = np.random.default_rng(0)
    scenario = pick_scenario("cube")(rng)
    actions = np.array([draw_action(scenario.proposal, Prior(uniform_share=0.0), rng) for _ in range(200)])
    assert np.abs(actions[:, :3] - scenario.proposal[:3]).max() < 0.08  # 5 sigma of 1.5 cm
    rotations = [pose9_to_matrix(a)[:3, :3] for a in actions]
    assert all(np.allclose(r @ r.T, np.eye(3), atol=1e-9) for r in rotations)
    wide = np.array([draw_action(scenario.proposal, Prior(uniform_share=1.0), rng) for _ in range(200)])
    assert np.abs(wide[:, :2]).max() > 0.08  # uniform draws reach well beyond the noise


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
    assert bad.returncode == 2 and "not a graspable" in bad.stdout
