"""The ``gfc`` command as a user runs it: a real subprocess, real files, exit codes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from gfc.examples import example_path, load_example


def gfc(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "gfc.cli", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=300,
    )


def test_help_teaches_the_first_commands() -> None:
    out = gfc("--help")
    assert out.returncode == 0
    assert "validate" in out.stdout and "bench" in out.stdout


def test_validate_prints_the_graph_and_exits_zero() -> None:
    out = gfc("validate", str(example_path("hammer_place")))
    assert out.returncode == 0, out.stderr
    assert "valid" in out.stdout and "regrasp.hammer" in out.stdout and "hammer@4" in out.stdout


def test_validate_json_output() -> None:
    out = gfc("validate", "--json", str(example_path("hammer_nail")))
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["valid"] and len(data["temporal_factors"]) == 10  # 11 steps; strike has no factor


def test_validate_lists_every_error_and_exits_two(tmp_path: Path) -> None:
    plan = load_example("hammer_place")
    plan["skeleton"][1]["robot"] = "right"
    plan["scene"]["objects"][0]["pose"][6] = 3.0
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(plan))
    out = gfc("validate", "--json", str(bad))
    assert out.returncode == 2
    locs = {e["loc"] for e in json.loads(out.stdout)["errors"]}
    assert "scene.objects[0].pose" in locs


def test_validate_missing_file_exits_two(tmp_path: Path) -> None:
    out = gfc("validate", str(tmp_path / "nope.json"))
    assert out.returncode == 2 and "does not exist" in out.stdout


@pytest.mark.slow
def test_bench_latency_writes_table_and_json(tmp_path: Path) -> None:
    out = gfc(
        "bench", "latency", "--repeats", "1", "--steps", "2", "--candidates", "2",
        "--json", str(tmp_path / "lat.json"), "--markdown", str(tmp_path / "lat.md"),
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    data = json.loads((tmp_path / "lat.json").read_text())
    for key in (
        "skeleton_steps",
        "candidates",
        "steps",
        "batched_seconds_median",
        "per_factor_seconds_median",
    ):
        assert key in data
    assert data["skeleton_steps"] == 11 and data["steps"] == 2 and data["candidates"] == 2
    assert data["batched_seconds_median"] > 0
    assert "| batched |" in (tmp_path / "lat.md").read_text()
