"""Durable job records with leases: SQLite by default, PostgreSQL when configured."""

from service.jobs.model import IdempotencyConflict, JobRecord, JobStatus
from service.jobs.store import JobStore, open_job_store

__all__ = ["IdempotencyConflict", "JobRecord", "JobStatus", "JobStore", "open_job_store"]
