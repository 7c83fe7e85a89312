"""Verification jobs end to end: HTTP submit, a worker executing in PyBullet, faults."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from gfc.planner.library import InMemoryLibrary
from gfc.pool import InlinePool
from gfc.sim.candidates import candidates_json
from gfc.tasks import sample_task
from service.jobs import JobStatus, open_job_store
from service.settings import Settings
from service.worker import verification_worker
from tests.service.conftest import running_server


def reference_request(seed: int = 0, broken: bool = False) -> dict[str, Any]:
    """The hammer_place task's hand-written solution as a verify request (optionally spoiled:
    the first pick aims 1 m above the lid, which no arm reaches)."""
    task = sample_task("hammer_place", seed)
    actions = [None if a is None else a.copy() for a in task.reference_actions]
    if broken:
        first = actions[0]
        assert first is not None
        first[2] += 1.0
    candidate = candidates_json(actions, task.plan, rank=0)
    return {"plan": task.plan.to_json_dict(), "candidates": [candidate]}


@pytest.mark.slow
def test_verify_job_runs_in_the_simulator(tmp_path: Path) -> None:
    settings = Settings(data_dir=tmp_path / "var")
    store = open_job_store(settings.job_store_url())
    with running_server(settings, InMemoryLibrary({})) as url:
        good = httpx.post(
            f"{url}/verify", json=reference_request(), headers={"Idempotency-Key": "ref-0"}, timeout=30
        )
        assert good.status_code == 202, good.text
        again = httpx.post(
            f"{url}/verify", json=reference_request(), headers={"Idempotency-Key": "ref-0"}, timeout=30
        )
        assert again.json()["job_id"] == good.json()["job_id"]  # a retried submission is the same job
        clash = httpx.post(
            f"{url}/verify",
            json=reference_request(broken=True),
            headers={"Idempotency-Key": "ref-0"},
            timeout=30,
        )
        assert clash.status_code == 409
        bad = httpx.post(f"{url}/verify", json=reference_request(broken=True), timeout=30)
        job_ids = [good.json()["job_id"], bad.json()["job_id"]]
        assert httpx.get(f"{url}/jobs/{job_ids[0]}", timeout=30).json()["status"] == "queued"

        worker = verification_worker(store, settings.data_dir, pool=InlinePool())
        for _ in job_ids:
            assert worker.run_once() is not None

        done = httpx.get(f"{url}/jobs/{job_ids[0]}", timeout=30).json()
        assert done["status"] == "succeeded", done
        result = done["result"]["candidates"][0]
        assert result["success"] and result["goal_satisfied"]
        assert [s["skill"] for s in result["steps"]][-1] == "place"
        assert result["frames"] == [f"/jobs/{job_ids[0]}/frames/rank0.png"]  # a link into the service
        frame = httpx.get(f"{url}{result['frames'][0]}", timeout=30)
        assert frame.status_code == 200 and frame.content[:8] == b"\x89PNG\r\n\x1a\n"

        failed = httpx.get(f"{url}/jobs/{job_ids[1]}", timeout=30).json()
        assert failed["status"] == "succeeded"  # the job ran; the candidate did not work
        outcome = failed["result"]["candidates"][0]
        assert not outcome["success"]
        assert outcome["steps"][0]["failure_type"] == 1  # unreachable: no IK
        assert httpx.get(f"{url}/jobs/nope", timeout=30).status_code == 404


def start_worker(database: str, data_dir: Path, lease: float) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "gfc.cli", "worker", "--database", database, "--data-dir", str(data_dir),
         "--lease", str(lease)],
        env={**os.environ, "OMP_NUM_THREADS": "1"},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        text=True,
    )  # fmt: skip


def wait_for(predicate: Any, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise TimeoutError("condition not reached in time")
        time.sleep(0.1)


@pytest.mark.slow
def test_killed_worker_job_is_finished_by_a_new_worker_exactly_once(tmp_path: Path) -> None:
    database = f"sqlite:///{tmp_path / 'jobs.db'}"
    store = open_job_store(database)
    job = store.submit("verify", {**reference_request(), "seed": 0})
    first = start_worker(database, tmp_path, lease=2.0)
    try:
        wait_for(lambda: (j := store.get(job.id)) is not None and j.status is JobStatus.RUNNING, 60)
        os.kill(first.pid, signal.SIGKILL)  # mid-job: no chance to clean up
        first.wait(timeout=10)
    finally:
        if first.poll() is None:
            first.kill()
    running = store.get(job.id)
    assert running is not None and running.status is JobStatus.RUNNING and running.attempts == 1
    second = start_worker(database, tmp_path, lease=2.0)
    try:
        wait_for(lambda: (j := store.get(job.id)) is not None and j.status is JobStatus.SUCCEEDED, 120)
    finally:
        second.terminate()
        second.wait(timeout=10)
    final = store.get(job.id)
    assert final is not None
    assert final.attempts == 2 and final.completions == 1
    assert final.result is not None and final.result["candidates"][0]["success"]


@pytest.mark.slow
def test_restarted_service_still_knows_its_jobs(tmp_path: Path) -> None:
    settings = Settings(data_dir=tmp_path / "var")
    with running_server(settings, InMemoryLibrary({})) as url:
        job_id = httpx.post(f"{url}/verify", json=reference_request(), timeout=30).json()["job_id"]
    with running_server(settings, InMemoryLibrary({})) as url:
        assert httpx.get(f"{url}/jobs/{job_id}", timeout=30).json()["status"] == "queued"
        worker = verification_worker(
            open_job_store(settings.job_store_url()), settings.data_dir, pool=InlinePool()
        )
        worker.run_once()
        assert httpx.get(f"{url}/jobs/{job_id}", timeout=30).json()["status"] == "succeeded"


@pytest.mark.slow
def test_plan_then_verify_by_plan_id_then_poll(tmp_path: Path) -> None:
    """The whole user flow over HTTP: plan, verify the returned plan by id, poll the job."""
    from gfc.plan import compile_plan
    from gfc.planner.library import random_library

    task = sample_task("hammer_place", 1)
    plan = task.plan.to_json_dict()
    plan["options"] = {"candidates": 3, "top_k": 2, "steps": 4, "seed": 0}
    library = random_library(compile_plan(task.plan))  # untrained: candidates will fail, honestly
    settings = Settings(data_dir=tmp_path / "var")
    with running_server(settings, library) as url:
        planned = httpx.post(f"{url}/plan", json=plan, timeout=120).json()
        accepted = httpx.post(f"{url}/verify", json={"plan_id": planned["plan_id"], "top_k": 2}, timeout=30)
        assert accepted.status_code == 202, accepted.text
        job_url = f"{url}{accepted.json()['url']}"
        worker = verification_worker(
            open_job_store(settings.job_store_url()), settings.data_dir, pool=InlinePool()
        )
        worker.run_once()
        job = httpx.get(job_url, timeout=30).json()
        assert job["status"] == "succeeded"
        ranks = [c["rank"] for c in job["result"]["candidates"]]
        assert ranks == [0, 1]
        for candidate in job["result"]["candidates"]:
            assert candidate["steps"], candidate  # at least the first step was attempted
            failed = [s for s in candidate["steps"] if not s["success"]]
            assert all(s["failure_type"] in (1, 2, 3) and s["reason"] for s in failed)
        missing = httpx.post(f"{url}/verify", json={"plan_id": "nope"}, timeout=30)
        assert missing.status_code == 404


@pytest.mark.slow
def test_verification_fans_out_over_a_ray_cluster(tmp_path: Path) -> None:
    """The same job through the Ray pool (a local cluster; GFC_RAY_ADDRESS names a real one)."""
    store = open_job_store(f"sqlite:///{tmp_path / 'jobs.db'}")
    request = reference_request()
    request["candidates"].append({**request["candidates"][0], "rank": 1})
    job = store.submit("verify", {**request, "seed": 0})
    worker = verification_worker(store, tmp_path, ray_address="local")
    worker.run_once()
    final = store.get(job.id)
    assert final is not None and final.status is JobStatus.SUCCEEDED, final
    assert final.result is not None
    assert [c["rank"] for c in final.result["candidates"]] == [0, 1]
    assert all(c["success"] for c in final.result["candidates"])
