"""``gfc serve`` as a user starts it: a subprocess on a free port, a skill store on disk."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest

from gfc.examples import load_example
from gfc.plan import compile_plan
from gfc.planner.library import random_library
from service.local_server import free_port
from skill_store import SkillStore


@contextmanager
def gfc_serve(store: Path, data_dir: Path, **env_extra: str) -> Iterator[str]:
    port = free_port()
    env = {**os.environ, "GFC_DATA_DIR": str(data_dir), "OMP_NUM_THREADS": "1", **env_extra}
    proc = subprocess.Popen(
        [sys.executable, "-m", "gfc.cli", "serve", "--port", str(port), "--store", str(store)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(f"{url}/health/live", timeout=2).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if proc.poll() is not None or time.monotonic() > deadline:
                output = proc.stdout.read() if proc.stdout else ""
                raise RuntimeError(f"gfc serve did not come up:\n{output}")
            time.sleep(0.2)
        yield url
    finally:
        proc.terminate()
        proc.wait(timeout=20)
        # Its embedded worker must not outlive it (generous: on a loaded machine a worker may
        # still be importing torch when its parent goes, and only then looks for the parent).
        deadline = time.monotonic() + 45
        while children_of(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not children_of(proc.pid), "gfc serve left its worker behind"


def children_of(pid: int) -> list[int]:
    """Worker processes started with ``--parent-pid PID`` (read from /proc)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            args = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"--parent-pid" in args and args[
            args.index(b"--parent-pid") + 1 : args.index(b"--parent-pid") + 2
        ] == [str(pid).encode()]:
            found.append(int(entry.name))
    return found


@pytest.mark.slow
def test_serve_plans_with_skills_from_the_store(tmp_path: Path) -> None:
    store = SkillStore(tmp_path / "skills")
    compiled = compile_plan(load_example("hammer_place"))
    for name, model in random_library(compiled).models.items():
        store.publish(name, model, {"seed": 0, "command": "tests: random weights"})
    plan = load_example("hammer_place")
    plan["options"] = {"candidates": 4, "top_k": 2, "steps": 5, "seed": 0}
    with gfc_serve(tmp_path / "skills", tmp_path / "var") as url:
        assert httpx.get(f"{url}/health/ready", timeout=60).status_code == 200
        skills = httpx.get(f"{url}/skills", timeout=60).json()
        assert {s["name"] for s in skills} == {
            "pick.hammer",
            "move.hammer",
            "regrasp.hammer",
            "place.hammer.box",
        }
        response = httpx.post(f"{url}/plan", json=plan, timeout=120)
        assert response.status_code == 200, response.text
        assert response.json()["models"]["pick.hammer"] == "pick.hammer@1"
    assert (tmp_path / "var").is_dir()


@pytest.mark.slow
def test_serve_with_an_empty_store_is_live_but_not_ready(tmp_path: Path) -> None:
    with gfc_serve(tmp_path / "empty", tmp_path / "var") as url:
        ready = httpx.get(f"{url}/health/ready", timeout=30)
        assert ready.status_code == 503
        plan = httpx.post(f"{url}/plan", json=load_example("hammer_place"), timeout=30)
        assert plan.status_code == 404


@pytest.mark.slow
def test_corrupted_version_is_refused_while_the_previous_keeps_serving(tmp_path: Path) -> None:
    root = tmp_path / "skills"
    store = SkillStore(root)
    compiled = compile_plan(load_example("hammer_place"))
    models = random_library(compiled).models
    for name, model in models.items():
        store.publish(name, model, {"seed": 0, "command": "tests: random weights"})
    plan = load_example("hammer_place")
    plan["options"] = {"candidates": 2, "top_k": 1, "steps": 3, "seed": 0}
    with gfc_serve(root, tmp_path / "var") as url:
        first = httpx.post(f"{url}/plan", json=plan, timeout=120)
        assert first.json()["models"]["pick.hammer"] == "pick.hammer@1"
        # A new version is published, then its weights rot on disk before anyone loads them.
        assert store.publish("pick.hammer", models["pick.hammer"], {"seed": 1, "command": "tests"}) == 2
        weights = root / "pick.hammer" / "2" / "model.safetensors"
        data = bytearray(weights.read_bytes())
        data[len(data) // 2] ^= 0xFF
        weights.write_bytes(bytes(data))
        time.sleep(2.5)  # the service re-reads skill states every 2 s
        second = httpx.post(f"{url}/plan", json=plan, timeout=120)
        assert second.status_code == 200, second.text
        assert second.json()["models"]["pick.hammer"] == "pick.hammer@1"  # still serving
        versions = {
            v["version"]: v for v in httpx.get(f"{url}/skills/pick.hammer", timeout=60).json()["versions"]
        }
        assert versions["1"]["ready"] and not versions["2"]["ready"]
        assert "sha256" in versions["2"]["detail"] or "hash" in versions["2"]["detail"]
        plan["skeleton"][0]["model"] = "pick.hammer@2"  # asking for it explicitly is refused
        pinned = httpx.post(f"{url}/plan", json=plan, timeout=120)
        assert pinned.status_code == 503
        assert pinned.json()["error"] == "skill version unavailable"


@pytest.mark.slow
def test_management_needs_the_token_and_moves_aliases(tmp_path: Path) -> None:
    root = tmp_path / "skills"
    store = SkillStore(root)
    models = random_library(compile_plan(load_example("hammer_place"))).models
    for name, model in models.items():
        store.publish(name, model, {"seed": 0, "command": "tests"})
    store.publish("pick.hammer", models["pick.hammer"], {"seed": 1, "command": "tests"})  # version 2
    token = "t0ken-for-tests-0123456789"
    plan = load_example("hammer_place")
    plan["options"] = {"candidates": 2, "top_k": 1, "steps": 3, "seed": 0}
    plan["skeleton"][0]["model"] = "pick.hammer@production"
    with gfc_serve(root, tmp_path / "var", GFC_MANAGEMENT_TOKEN=token) as url:
        move = {"version": 1, "reason": "roll back"}
        assert (
            httpx.put(f"{url}/admin/skills/pick.hammer/aliases/production", json=move, timeout=30).status_code
            == 401
        )
        wrong = {"Authorization": "Bearer nope"}
        assert (
            httpx.put(
                f"{url}/admin/skills/pick.hammer/aliases/production", json=move, headers=wrong, timeout=30
            ).status_code
            == 401
        )
        auth = {"Authorization": f"Bearer {token}"}
        moved = httpx.put(
            f"{url}/admin/skills/pick.hammer/aliases/production", json=move, headers=auth, timeout=30
        )
        assert moved.status_code == 200, moved.text
        assert (
            httpx.post(f"{url}/plan", json=plan, timeout=120).json()["models"]["pick.hammer@production"]
            == "pick.hammer@1"
        )
        move["version"] = 2
        httpx.put(f"{url}/admin/skills/pick.hammer/aliases/production", json=move, headers=auth, timeout=30)
        assert (
            httpx.post(f"{url}/plan", json=plan, timeout=120).json()["models"]["pick.hammer@production"]
            == "pick.hammer@2"
        )
        loaded = httpx.post(f"{url}/admin/skills/place.hammer.box/load", headers=auth, timeout=60)
        assert loaded.json() == {"loaded": "place.hammer.box@1"}
        assert (
            httpx.post(f"{url}/admin/skills/pick.hammer/unload", headers=auth, timeout=30).json()["unloaded"]
            == 2
        )
    assert [e.alias for e in store.audit_log("pick.hammer")][-2:] == ["production", "production"]
