"""Job stores: one SQL schema, two dialects (SQLite file by default, PostgreSQL when scaled).

Every operation is one short transaction on a fresh connection, so the service and any number
of worker processes can share a store, and a crash anywhere leaves only committed state.
Claiming is the one contended operation: SQLite serialises it with ``BEGIN IMMEDIATE``;
PostgreSQL uses ``SELECT ... FOR UPDATE SKIP LOCKED`` so workers never wait on each other.
"""

from __future__ import annotations

import json
import sqlite3
import time
import uuid
from abc import ABC, abstractmethod
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from service.jobs.model import IdempotencyConflict, JobRecord, JobStatus

SCHEMA = """
CREATE TABLE IF NOT EXISTS gfc_jobs (
    id TEXT PRIMARY KEY,
    kind TEXT NOT NULL,
    status TEXT NOT NULL,
    payload TEXT NOT NULL,
    attempts INTEGER NOT NULL DEFAULT 0,
    max_attempts INTEGER NOT NULL,
    idempotency_key TEXT UNIQUE,
    lease_owner TEXT,
    lease_expires_at DOUBLE PRECISION,
    result TEXT,
    error TEXT,
    created_at DOUBLE PRECISION NOT NULL,
    updated_at DOUBLE PRECISION NOT NULL,
    completions INTEGER NOT NULL DEFAULT 0
)
"""
INDEX = "CREATE INDEX IF NOT EXISTS gfc_jobs_claim ON gfc_jobs (status, created_at)"
PLANS = """
CREATE TABLE IF NOT EXISTS gfc_plans (
    id TEXT PRIMARY KEY,
    body TEXT NOT NULL,
    created_at DOUBLE PRECISION NOT NULL
)
"""
CLAIMABLE = "(status = 'queued' OR (status = 'running' AND lease_expires_at < {p}))"


class JobStore(ABC):
    """Durable job records with leases, heartbeats, an attempt cap and idempotency keys."""

    placeholder = "?"

    @abstractmethod
    @contextmanager
    def _transaction(self, claim: bool = False) -> Iterator[Any]:
        """A cursor inside one transaction (``claim``: the claiming kind of transaction)."""

    def _sql(self, text: str) -> str:
        return text.replace("{p}", self.placeholder)

    def submit(
        self, kind: str, payload: dict[str, Any], idempotency_key: str | None = None, max_attempts: int = 3
    ) -> JobRecord:
        """Queue a job. With an ``idempotency_key`` seen before, return that job instead (and
        refuse a different payload under the same key)."""
        now = time.time()
        body = json.dumps(payload, sort_keys=True)
        job_id = uuid.uuid4().hex
        with self._transaction(claim=True) as cur:
            if idempotency_key is not None:
                cur.execute(
                    self._sql(f"SELECT {JobRecord.COLUMNS} FROM gfc_jobs WHERE idempotency_key = {{p}}"),
                    (idempotency_key,),
                )
                row = cur.fetchone()
                if row is not None:
                    existing = JobRecord.from_row(row)
                    if json.dumps(existing.payload, sort_keys=True) != body or existing.kind != kind:
                        raise IdempotencyConflict(
                            f"idempotency key {idempotency_key!r} was used for a different request (job {existing.id})"
                        )
                    return existing
            cur.execute(
                self._sql(
                    "INSERT INTO gfc_jobs (id, kind, status, payload, max_attempts, idempotency_key, "
                    "created_at, updated_at) VALUES ({p}, {p}, 'queued', {p}, {p}, {p}, {p}, {p})"
                ),
                (job_id, kind, body, max_attempts, idempotency_key, now, now),
            )
        job = self.get(job_id)
        assert job is not None
        return job

    def get(self, job_id: str) -> JobRecord | None:
        with self._transaction() as cur:
            cur.execute(self._sql(f"SELECT {JobRecord.COLUMNS} FROM gfc_jobs WHERE id = {{p}}"), (job_id,))
            row = cur.fetchone()
        return None if row is None else JobRecord.from_row(row)

    def claim(self, worker: str, lease_s: float) -> JobRecord | None:
        """Take the oldest queued job, or one whose worker stopped renewing its lease. Jobs that
        used up their attempts are failed on the way instead of being run again."""
        while True:
            now = time.time()
            with self._transaction(claim=True) as cur:
                cur.execute(self._select_claimable(), (now,))
                row = cur.fetchone()
                if row is None:
                    return None
                job = JobRecord.from_row(row)
                if job.attempts >= job.max_attempts:
                    cur.execute(
                        self._sql(
                            "UPDATE gfc_jobs SET status = 'failed', lease_owner = NULL, error = {p}, "
                            "updated_at = {p} WHERE id = {p}"
                        ),
                        (
                            f"gave up after {job.attempts} attempts: the worker stopped (lease expired)",
                            now,
                            job.id,
                        ),
                    )
                    continue
                cur.execute(
                    self._sql(
                        "UPDATE gfc_jobs SET status = 'running', lease_owner = {p}, lease_expires_at = {p}, "
                        "attempts = attempts + 1, updated_at = {p} WHERE id = {p}"
                    ),
                    (worker, now + lease_s, now, job.id),
                )
            claimed = self.get(job.id)
            assert claimed is not None
            return claimed

    def _select_claimable(self) -> str:
        where = CLAIMABLE.replace("{p}", self.placeholder)
        return f"SELECT {JobRecord.COLUMNS} FROM gfc_jobs WHERE {where} ORDER BY created_at LIMIT 1"

    def heartbeat(self, job_id: str, worker: str, lease_s: float) -> bool:
        """Extend the lease; False when this worker no longer holds the job."""
        now = time.time()
        with self._transaction() as cur:
            cur.execute(
                self._sql(
                    "UPDATE gfc_jobs SET lease_expires_at = {p}, updated_at = {p} "
                    "WHERE id = {p} AND lease_owner = {p} AND status = 'running'"
                ),
                (now + lease_s, now, job_id, worker),
            )
            return bool(cur.rowcount == 1)

    def complete(self, job_id: str, worker: str, result: dict[str, Any]) -> bool:
        """Record the result if this worker still holds the lease (else False: someone else
        took the job over, and their completion is the one that counts)."""
        now = time.time()
        with self._transaction() as cur:
            cur.execute(
                self._sql(
                    "UPDATE gfc_jobs SET status = 'succeeded', result = {p}, lease_owner = NULL, "
                    "lease_expires_at = NULL, completions = completions + 1, updated_at = {p} "
                    "WHERE id = {p} AND lease_owner = {p} AND status = 'running'"
                ),
                (json.dumps(result), now, job_id, worker),
            )
            return bool(cur.rowcount == 1)

    def fail(self, job_id: str, worker: str, error: str, retry: bool = True) -> bool:
        """Give the job back (queued, if attempts remain and ``retry``) or mark it failed."""
        now = time.time()
        with self._transaction() as cur:
            cur.execute(
                self._sql(
                    "UPDATE gfc_jobs SET status = CASE WHEN {p} AND attempts < max_attempts "
                    "THEN 'queued' ELSE 'failed' END, error = {p}, lease_owner = NULL, "
                    "lease_expires_at = NULL, updated_at = {p} "
                    "WHERE id = {p} AND lease_owner = {p} AND status = 'running'"
                ),
                (retry, error, now, job_id, worker),
            )
            return bool(cur.rowcount == 1)

    def save_plan(self, plan_id: str, body: dict[str, Any]) -> None:
        """Keep a planned request and its candidates, so ``POST /verify`` can name it by id."""
        with self._transaction() as cur:
            cur.execute(
                self._sql("INSERT INTO gfc_plans (id, body, created_at) VALUES ({p}, {p}, {p})"),
                (plan_id, json.dumps(body), time.time()),
            )

    def get_plan(self, plan_id: str) -> dict[str, Any] | None:
        with self._transaction() as cur:
            cur.execute(self._sql("SELECT body FROM gfc_plans WHERE id = {p}"), (plan_id,))
            row = cur.fetchone()
        return None if row is None else dict(json.loads(row[0]))

    def counts(self) -> dict[str, int]:
        with self._transaction() as cur:
            cur.execute("SELECT status, COUNT(*) FROM gfc_jobs GROUP BY status")
            rows = cur.fetchall()
        out = {s.value: 0 for s in JobStatus}
        out.update({str(status): int(n) for status, n in rows})
        return out


class SqliteJobStore(JobStore):
    """A job database in one file (WAL mode: readers do not block the writer)."""

    placeholder = "?"

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._transaction() as cur:
            cur.execute(SCHEMA)
            cur.execute(INDEX)
            cur.execute(PLANS)
        connection = self._connect()
        connection.execute("PRAGMA journal_mode=WAL")
        connection.close()

    def _connect(self) -> sqlite3.Connection:
        connection = sqlite3.connect(self.path, timeout=30, isolation_level=None)
        connection.execute("PRAGMA busy_timeout = 30000")
        return connection

    @contextmanager
    def _transaction(self, claim: bool = False) -> Iterator[Any]:
        connection = self._connect()
        try:
            cur = connection.cursor()
            cur.execute("BEGIN IMMEDIATE" if claim else "BEGIN")
            try:
                yield cur
            except BaseException:
                connection.rollback()
                raise
            connection.commit()
        finally:
            connection.close()


class PostgresJobStore(JobStore):
    placeholder = "%s"

    def __init__(self, url: str) -> None:
        import psycopg

        self._psycopg = psycopg
        self.url = url
        with self._transaction() as cur:
            cur.execute("SELECT pg_advisory_xact_lock(4242)")  # two processes creating the table at once
            cur.execute(SCHEMA)
            cur.execute(INDEX)
            cur.execute(PLANS)

    @contextmanager
    def _transaction(self, claim: bool = False) -> Iterator[Any]:
        with self._psycopg.connect(self.url, connect_timeout=10) as connection, connection.cursor() as cur:
            yield cur  # psycopg commits on leaving the connection block, rolls back on error

    def _select_claimable(self) -> str:
        return super()._select_claimable() + " FOR UPDATE SKIP LOCKED"


def open_job_store(url: str) -> JobStore:
    """``sqlite:///path/to/jobs.db`` (or a plain path) or ``postgresql://...``."""
    if url.startswith(("postgresql://", "postgres://")):
        return PostgresJobStore(url)
    if url.startswith("sqlite:///"):
        return SqliteJobStore(url[len("sqlite:///") :])
    if "://" in url:
        raise ValueError(f"unsupported job store URL {url!r}: use sqlite:///PATH or postgresql://...")
    return SqliteJobStore(url)
