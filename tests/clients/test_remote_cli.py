"""``gfc plan`` locally and with --url, and ``verify_remote`` (``gfc verify --url``)."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from gfc.cli.remote import register_remote_commands, verify_remote
from gfc.examples import example_path, load_example
from gfc.planner.library import InMemoryLibrary
from skill_store import SkillStore
from tests.clients.conftest import VERIFIED, Service, free_port, small

SMALL = ["--candidates", "4", "--top-k", "2", "--steps", "4"]


def cli() -> typer.Typer:
    app = typer.Typer()

    @app.callback()
    def root() -> None:
        """gfc"""

    register_remote_commands(app)
    return app


def invoke(*args: str) -> Any:
    return CliRunner().invoke(cli(), list(args), env={"COLUMNS": "200", "GFC_URL": ""})


@pytest.fixture
def store(library: InMemoryLibrary, tmp_path: Path) -> str:
    skills = SkillStore(tmp_path / "skills")
    for name, model in library.models.items():
        skills.publish(name, model)
    return str(tmp_path / "skills")


def test_help_teaches_both_modes() -> None:
    result = invoke("plan", "--help")
    assert result.exit_code == 0
    for text in ("--url", "--out", "--store", "gfc verify", "Examples"):
        assert text in result.output


def test_plan_locally_with_the_skill_store(store: str, tmp_path: Path) -> None:
    out = tmp_path / "run" / "candidates.json"
    result = invoke("plan", str(example_path("hammer_place")), "--store", store, "--out", str(out), *SMALL)
    assert result.exit_code == 0, result.output
    assert "pick.hammer -> pick.hammer@1" in result.output
    written = json.loads(out.read_text())
    assert [c["rank"] for c in written["candidates"]] == [0, 1]
    assert "plan_id" not in written
    assert [s["skill"] for s in written["candidates"][0]["steps"]] == ["pick", "move", "regrasp", "place"]


def test_plan_locally_reports_every_problem(store: str, tmp_path: Path) -> None:
    plan = load_example("hammer_place")
    plan["skeleton"][1]["robot"] = "right"
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(plan))
    result = invoke("plan", str(path), "--store", store)
    assert result.exit_code == 2
    assert "skeleton[1].object" in result.output
    missing = invoke("plan", str(tmp_path / "nope.json"))
    assert missing.exit_code == 2 and "does not exist" in missing.output


def test_plan_locally_with_a_skill_the_store_lacks(tmp_path: Path) -> None:
    result = invoke("plan", str(example_path("hammer_place")), "--store", str(tmp_path / "empty"), *SMALL)
    assert result.exit_code == 2
    assert "gfc skills list" in result.output


def test_plan_remotely_then_verify_the_written_candidates(service: Service, tmp_path: Path) -> None:
    out = tmp_path / "candidates.json"
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(json.dumps(small(load_example("hammer_place"))))
    result = invoke("plan", str(plan_file), "--url", service.url, "--out", str(out))
    assert result.exit_code == 0, result.output
    assert "plan_id:" in result.output
    assert len(json.loads(out.read_text())["candidates"]) == 2
    assert json.loads(out.read_text())["plan_id"]

    assert verify_remote(plan_file, out, service.url, wait=False) == 0
    queued = service.jobs.counts()
    assert queued.get("queued") == 1, queued

    stop = threading.Event()
    completed: list[str] = []

    def worker() -> None:  # plays a verification worker: completes every job it can claim
        while not stop.is_set():
            job = service.jobs.claim("test-worker", lease_s=30)
            if job is None:
                time.sleep(0.05)
                continue
            service.jobs.complete(job.id, "test-worker", VERIFIED)
            completed.append(job.id)

    thread = threading.Thread(target=worker)
    thread.start()
    try:
        code = verify_remote(plan_file, out, service.url, wait=True, timeout=20)
    finally:
        stop.set()
        thread.join()
    assert len(completed) == 2  # the queued one and the one we waited for
    assert code == 0


def test_verify_remote_exit_codes(
    service: Service, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(json.dumps(load_example("hammer_place")))
    candidates = tmp_path / "candidates.json"
    candidates.write_text(json.dumps({"candidates": []}))
    assert verify_remote(plan_file, candidates, service.url, wait=False) == 2  # nothing to verify
    assert "expected" in capsys.readouterr().out

    step = {"step": 0, "skill": "pick", "action": [0.0] * 9}
    candidates.write_text(json.dumps([{"rank": 0, "steps": [step]}]))
    bad_plan = tmp_path / "bad.json"
    bad_plan.write_text(json.dumps({"scene": {}}))
    assert verify_remote(bad_plan, candidates, service.url, wait=False) == 2  # the service says 422
    assert "422" in capsys.readouterr().out

    unreachable = f"http://127.0.0.1:{free_port()}"
    assert verify_remote(plan_file, candidates, unreachable, wait=False) == 1
    assert "gfc serve" in capsys.readouterr().out

    assert verify_remote(plan_file, candidates, service.url, wait=True, timeout=0.3) == 1  # nobody works it
    assert "still queued" in capsys.readouterr().out


def test_plan_remotely_reports_service_errors(service: Service, tmp_path: Path) -> None:
    plan = small(load_example("hammer_place"))
    plan["skeleton"][0]["model"] = "pick.anvil"
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan))
    result = invoke("plan", str(path), "--url", service.url)
    assert result.exit_code == 2
    assert "pick.anvil" in result.output and "request id" in result.output
