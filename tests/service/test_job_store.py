"""Job store semantics on SQLite and on a real PostgreSQL server.

PostgreSQL runs when GFC_TEST_DATABASE_URL is set (.ci/run sets it); elsewhere those cases skip
with that reason.
"""

from __future__ import annotations

import os
import threading
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from service.jobs import IdempotencyConflict, JobStatus, JobStore, open_job_store

PG_URL = os.environ.get("GFC_TEST_DATABASE_URL")


@pytest.fixture(params=["sqlite", "postgresql"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[JobStore]:
    if request.param == "sqlite":
        yield open_job_store(f"sqlite:///{tmp_path / 'jobs.db'}")
        return
    if not PG_URL:
        pytest.skip("set GFC_TEST_DATABASE_URL=postgresql://... to run the PostgreSQL job store tests")
    import psycopg

    schema = f"t_{uuid.uuid4().hex[:12]}"
    with psycopg.connect(PG_URL, autocommit=True) as conn:
        conn.execute(f"CREATE SCHEMA {schema}")
    sep = "&" if "?" in PG_URL else "?"
    try:
        yield open_job_store(f"{PG_URL}{sep}options=-csearch_path%3D{schema}")
    finally:
        with psycopg.connect(PG_URL, autocommit=True) as conn:
            conn.execute(f"DROP SCHEMA {schema} CASCADE")


def test_submit_claim_complete(store: JobStore) -> None:
    job = store.submit("verify", {"plan": 1})
    assert job.status is JobStatus.QUEUED and job.attempts == 0
    claimed = store.claim("w1", lease_s=30)
    assert claimed is not None and claimed.id == job.id
    assert claimed.status is JobStatus.RUNNING and claimed.attempts == 1 and claimed.lease_owner == "w1"
    assert store.claim("w2", lease_s=30) is None  # nothing else to do
    assert store.complete(job.id, "w1", {"ok": True})
    done = store.get(job.id)
    assert done is not None and done.status is JobStatus.SUCCEEDED and done.result == {"ok": True}
    assert done.completions == 1


def test_jobs_are_claimed_oldest_first(store: JobStore) -> None:
    first = store.submit("verify", {"n": 1})
    time.sleep(0.01)
    store.submit("verify", {"n": 2})
    claimed = store.claim("w", lease_s=30)
    assert claimed is not None and claimed.id == first.id


def test_idempotency_key_returns_the_same_job_and_refuses_a_different_payload(store: JobStore) -> None:
    a = store.submit("verify", {"plan": 1}, idempotency_key="k-1")
    b = store.submit("verify", {"plan": 1}, idempotency_key="k-1")
    assert a.id == b.id
    with pytest.raises(IdempotencyConflict):
        store.submit("verify", {"plan": 2}, idempotency_key="k-1")
    assert store.counts()["queued"] == 1


def test_expired_lease_is_taken_over_and_the_old_worker_cannot_complete(store: JobStore) -> None:
    job = store.submit("verify", {})
    assert store.claim("dead", lease_s=0.05) is not None
    time.sleep(0.1)
    taken = store.claim("alive", lease_s=30)
    assert taken is not None and taken.id == job.id and taken.attempts == 2
    assert not store.heartbeat(job.id, "dead", 30)
    assert not store.complete(job.id, "dead", {"from": "dead"})  # lost its lease
    assert store.complete(job.id, "alive", {"from": "alive"})
    final = store.get(job.id)
    assert final is not None and final.result == {"from": "alive"} and final.completions == 1


def test_heartbeat_keeps_the_lease(store: JobStore) -> None:
    job = store.submit("verify", {})
    store.claim("w", lease_s=0.2)
    for _ in range(4):
        time.sleep(0.1)
        assert store.heartbeat(job.id, "w", 0.2)
    assert store.claim("other", lease_s=30) is None


def test_attempt_cap_fails_a_job_whose_workers_keep_dying(store: JobStore) -> None:
    job = store.submit("verify", {}, max_attempts=2)
    for worker in ("a", "b"):
        assert store.claim(worker, lease_s=0.01) is not None
        time.sleep(0.03)
    assert store.claim("c", lease_s=30) is None
    final = store.get(job.id)
    assert final is not None and final.status is JobStatus.FAILED
    assert final.error is not None and "gave up after 2 attempts" in final.error


def test_fail_requeues_until_attempts_run_out(store: JobStore) -> None:
    job = store.submit("verify", {}, max_attempts=2)
    store.claim("w", lease_s=30)
    assert store.fail(job.id, "w", "simulator crashed")
    again = store.get(job.id)
    assert again is not None and again.status is JobStatus.QUEUED
    store.claim("w", lease_s=30)
    assert store.fail(job.id, "w", "simulator crashed again")
    final = store.get(job.id)
    assert final is not None and final.status is JobStatus.FAILED and final.error == "simulator crashed again"


def test_concurrent_claimers_never_share_a_job(store: JobStore) -> None:
    ids = {store.submit("verify", {"n": i}).id for i in range(12)}
    claimed: list[str] = []
    lock = threading.Lock()

    def worker(name: str) -> None:
        while (job := store.claim(name, lease_s=30)) is not None:
            with lock:
                claimed.append(job.id)
            store.complete(job.id, name, {})

    threads = [threading.Thread(target=worker, args=(f"w{i}",)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(claimed) == sorted(ids)  # each job exactly once
    assert store.counts()["succeeded"] == 12


def test_a_new_store_on_the_same_database_sees_every_job(tmp_path: Path) -> None:
    """A restarted service loses nothing: the records are in the file."""
    url = f"sqlite:///{tmp_path / 'jobs.db'}"
    job = open_job_store(url).submit("verify", {"plan": 3})
    reopened = open_job_store(url)
    again = reopened.get(job.id)
    assert again is not None and again.payload == {"plan": 3}


def test_unsupported_url_is_refused_with_advice() -> None:
    with pytest.raises(ValueError, match="sqlite:///PATH or postgresql"):
        open_job_store("mysql://localhost/jobs")
