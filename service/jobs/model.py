"""A job record and its life cycle.

    queued --claim--> running --complete--> succeeded
                         |  \\--fail (attempts left)--> queued
                         |   \\-fail (none left)------> failed
                         \\--lease expires: another worker may claim it (attempts + 1); once
                            the attempt cap is reached it is failed instead.

Only the worker holding the current lease can complete a job, and completion is one guarded
UPDATE, so a job never completes twice (a worker that lost its lease finds its result refused).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from enum import StrEnum
from typing import Any


class JobStatus(StrEnum):
    QUEUED = "queued"
    RUNNING = "running"
    SUCCEEDED = "succeeded"
    FAILED = "failed"


class IdempotencyConflict(Exception):
    """The idempotency key was used before for a different request."""


@dataclass(frozen=True)
class JobRecord:
    id: str
    kind: str
    status: JobStatus
    payload: dict[str, Any]
    attempts: int
    max_attempts: int
    idempotency_key: str | None
    lease_owner: str | None
    lease_expires_at: float | None
    result: dict[str, Any] | None
    error: str | None
    created_at: float
    updated_at: float
    completions: int

    COLUMNS = (
        "id, kind, status, payload, attempts, max_attempts, idempotency_key, lease_owner, "
        "lease_expires_at, result, error, created_at, updated_at, completions"
    )

    @staticmethod
    def from_row(row: tuple[Any, ...]) -> JobRecord:
        return JobRecord(
            id=row[0],
            kind=row[1],
            status=JobStatus(row[2]),
            payload=json.loads(row[3]),
            attempts=int(row[4]),
            max_attempts=int(row[5]),
            idempotency_key=row[6],
            lease_owner=row[7],
            lease_expires_at=row[8],
            result=None if row[9] is None else json.loads(row[9]),
            error=row[10],
            created_at=float(row[11]),
            updated_at=float(row[12]),
            completions=int(row[13]),
        )

    def public(self) -> dict[str, Any]:
        """What GET /jobs/{id} shows (no lease internals beyond the owner)."""
        return {
            "id": self.id,
            "kind": self.kind,
            "status": self.status.value,
            "attempts": self.attempts,
            "max_attempts": self.max_attempts,
            "worker": self.lease_owner,
            "result": self.result,
            "error": self.error,
            "created_at": self.created_at,
            "updated_at": self.updated_at,
        }
