"""The library pipeline end to end on a tiny budget: collect, train, publish, check (CI-sized)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from skill_store import SkillStore


def gfc(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "gfc.cli", *args], capture_output=True, text=True, timeout=900
    )


@pytest.mark.slow
def test_tiny_build_publishes_and_checks_a_model(tmp_path: Path) -> None:
    store, data, report = tmp_path / "store", tmp_path / "data", tmp_path / "build.json"
    built = gfc("library", "build", "--budget", "tiny", "--only", "pick.cube", "--store", str(store),
                "--data", str(data), "--report", str(report))  # fmt: skip
    assert built.returncode == 0, built.stdout + built.stderr
    summary = json.loads(report.read_text())
    (entry,) = summary["models"]
    assert entry["model"] == "pick.cube" and entry["rows"] >= 2 and summary["total_s"] > 0
    manifest = SkillStore(store).manifest("pick.cube@latest")
    assert manifest.weights.dtype == "bfloat16"
    assert manifest.training.data_hash and "data_success_rate" in manifest.training.metrics
    assert (data / "pick.cube" / "loss.png").stat().st_size > 1000

    checked = gfc(
        "skills", "check", "pick.cube", "-n", "3", "--store", str(store), "--json", str(tmp_path / "c.json")
    )
    assert checked.returncode == 0, checked.stdout + checked.stderr
    result = json.loads((tmp_path / "c.json").read_text())
    assert {"hit_rate", "random_hit_rate", "trials", "data_success_rate"} <= set(result)
    assert result["trials"] == 3 and 0.0 <= result["hit_rate"] <= 1.0
    assert sum(result["failures"].values()) == round(3 * (1 - result["hit_rate"]))

    missing = gfc("skills", "check", "pick.cube@7", "-n", "1", "--store", str(store))
    assert missing.returncode != 0 and "pick.cube" in missing.stdout + missing.stderr
    unknown = gfc("skills", "check", "fly.cube", "-n", "1", "--store", str(store))
    assert unknown.returncode == 2 and "no scene sampler" in unknown.stderr

    again = gfc("library", "build", "--budget", "tiny", "--only", "pick.cube", "--store", str(store),
                "--data", str(data))  # fmt: skip
    assert again.returncode == 0 and "already built: version 1" in again.stdout + again.stderr
    rebuilt = gfc("library", "build", "--budget", "tiny", "--only", "pick.cube", "--store", str(store),
                  "--data", str(data), "--rebuild")  # fmt: skip
    assert rebuilt.returncode == 0, rebuilt.stdout + rebuilt.stderr
    assert SkillStore(store).versions("pick.cube") == (1, 2)
