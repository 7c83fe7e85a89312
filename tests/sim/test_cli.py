"""``gfc sim demo`` and ``gfc verify`` from the command line (typer's test runner)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import typer
from PIL import Image
from typer.testing import CliRunner

from gfc.sim.cli import register_sim_commands, sim_app
from gfc.tasks import sample_task

runner = CliRunner()


def _app() -> typer.Typer:
    app = typer.Typer()
    register_sim_commands(app)
    app.add_typer(sim_app, name="sim")
    return app


@pytest.mark.slow
def test_demo_writes_frames_and_verify_replays_the_candidates(tmp_path: Path) -> None:
    app = _app()
    result = runner.invoke(
        app,
        [
            "sim",
            "demo",
            "pot_reorientation",
            "--seed",
            "2",
            "--out",
            str(tmp_path / "frames"),
            "--candidates",
            str(tmp_path / "run"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "SUCCESS" in result.output
    strip = Image.open(tmp_path / "frames" / "strip.png")
    assert strip.size[0] > 300
    first = Image.open(tmp_path / "frames" / "frame_00.png")
    assert first.size == (640, 480)

    candidates = json.loads((tmp_path / "run" / "candidates.json").read_text())
    broken = json.loads(json.dumps(candidates["candidates"][0]))
    broken["rank"] = 1
    broken["steps"][2]["action"][0] += 0.3  # pull the left hand off the pot: fixed transform broken
    candidates["candidates"].append(broken)
    (tmp_path / "run" / "candidates.json").write_text(json.dumps(candidates))
    out_json = tmp_path / "outcomes.json"
    result = runner.invoke(
        app,
        [
            "verify",
            str(tmp_path / "run" / "plan.json"),
            str(tmp_path / "run" / "candidates.json"),
            "--json",
            str(out_json),
        ],
    )
    assert result.exit_code == 0, result.output
    outcomes = json.loads(out_json.read_text())["results"]
    assert [o["success"] for o in outcomes] == [True, False]
    assert outcomes[1]["steps"][-1]["failure_type"] == 1


def test_verify_rejects_candidates_for_another_plan(tmp_path: Path) -> None:
    app = _app()
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps(sample_task("hammer_place", 0).plan.to_json_dict()))
    bad = {"candidates": [{"rank": 0, "steps": [{"step": 0, "skill": "place", "action": [0.0] * 9}]}]}
    (tmp_path / "c.json").write_text(json.dumps(bad))
    result = runner.invoke(app, ["verify", str(plan), str(tmp_path / "c.json")])
    assert result.exit_code == 2
    assert "skill 'place' but the plan says 'pick'" in result.output


def test_demo_rejects_unknown_tasks() -> None:
    result = runner.invoke(_app(), ["sim", "demo", "juggling"])
    assert result.exit_code != 0
    assert "unknown task" in result.output


def test_help_explains_failure_types() -> None:
    result = runner.invoke(_app(), ["sim", "--help"])
    assert result.exit_code == 0
    assert "no collision-free path" in result.output
