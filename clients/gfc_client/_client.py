"""``Client`` and ``AsyncClient``: the same calls, driven synchronously or with asyncio.

Everything that decides something (request bodies, idempotency keys, retries, parsing, errors,
polling) lives in ``_operations`` and ``_flow``; the classes here only send and sleep.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Mapping, Sequence
from types import TracebackType
from typing import Self, TypeVar

import httpx

from gfc_client import _operations as ops
from gfc_client._flow import Flow, Operation, Outcome, Sleep, call, wait_for_job
from gfc_client._operations import CandidateLike, PlanLike
from gfc_client._retry import RetryPolicy
from gfc_client._settings import DEFAULT_MAX_RETRIES, DEFAULT_TIMEOUT, ClientSettings, Timeout, build_request
from gfc_client.models import Health, Job, JobAccepted, PlanResponse, Readiness, Skill

T = TypeVar("T")


class _Base:
    def __init__(
        self,
        base_url: str | None,
        timeout: Timeout,
        max_retries: int,
        retry: RetryPolicy | None,
        headers: Mapping[str, str] | None,
    ) -> None:
        self.settings = ClientSettings.create(base_url, timeout, max_retries, retry, headers)

    @property
    def base_url(self) -> str:
        return self.settings.base_url

    def _flow(self, operation: Operation[T], timeout: Timeout) -> Flow[T]:
        return call(operation, self.settings.retry, timeout)

    def _wait_flow(
        self, job_id: str, timeout: float, poll_interval: float, request_timeout: Timeout
    ) -> Flow[Job]:
        return wait_for_job(ops.get_job(job_id), self.settings.retry, request_timeout, timeout, poll_interval)


class Client(_Base):
    """Synchronous client. ``base_url`` defaults to ``$GFC_URL`` or http://127.0.0.1:8000.

    Every call takes a keyword-only ``timeout`` (seconds, or an ``httpx.Timeout``) that
    overrides the client's for that call. Failed calls are retried ``max_retries`` times on
    connection errors, 408, 429 and 5xx, waiting as the server's ``Retry-After`` says or with
    exponential backoff and jitter.
    """

    def __init__(
        self,
        base_url: str | None = None,
        *,
        timeout: Timeout = DEFAULT_TIMEOUT,
        max_retries: int = DEFAULT_MAX_RETRIES,
        retry: RetryPolicy | None = None,
        headers: Mapping[str, str] | None = None,
        http_client: httpx.Client | None = None,
    ) -> None:
        super().__init__(base_url, timeout, max_retries, retry, headers)
        self._owns_http = http_client is None
        self._http = http_client or httpx.Client()
        self._http.base_url = httpx.URL(self.settings.base_url)
        self._http.headers.update(self.settings.headers)

    def _run(self, flow: Flow[T]) -> T:
        outcome: Outcome = None
        try:
            while True:
                action = flow.send(outcome)
                if isinstance(action, Sleep):
                    time.sleep(action.seconds)
                    outcome = None
                    continue
                try:
                    outcome = self._http.send(build_request(self._http, action, self.settings.timeout))
                except httpx.TransportError as exc:
                    outcome = exc
        except StopIteration as stop:
            result: T = stop.value
            return result

    # ---- planning ------------------------------------------------------------------------
    def plan(self, plan: PlanLike, *, request_id: str | None = None, timeout: Timeout = None) -> PlanResponse:
        """Sample continuous parameters for every step of ``plan`` (a dict or a ``PlanBuilder``)."""
        return self._run(self._flow(ops.plan(plan, request_id), timeout))

    # ---- verification jobs ---------------------------------------------------------------
    def verify(
        self,
        *,
        plan: PlanLike | None = None,
        candidates: Sequence[CandidateLike] | None = None,
        plan_id: str | None = None,
        top_k: int | None = None,
        seed: int = 0,
        max_attempts: int = 3,
        idempotency_key: str | None = None,
        timeout: Timeout = None,
    ) -> JobAccepted:
        """Queue a simulator verification job for ``plan_id`` (from ``plan()``) or for ``plan``
        with ``candidates``. Retries reuse one idempotency key, so they never queue twice."""
        operation = ops.verify(
            plan=plan,
            candidates=candidates,
            plan_id=plan_id,
            top_k=top_k,
            seed=seed,
            max_attempts=max_attempts,
            idempotency_key=idempotency_key,
        )
        return self._run(self._flow(operation, timeout))

    def get_job(self, job_id: str, *, timeout: Timeout = None) -> Job:
        return self._run(self._flow(ops.get_job(job_id), timeout))

    def wait_for_job(
        self,
        job_id: str,
        *,
        timeout: float = 600.0,
        poll_interval: float = 1.0,
        request_timeout: Timeout = None,
    ) -> Job:
        """Poll until the job has succeeded or failed; ``JobWaitTimeout`` after ``timeout`` s."""
        return self._run(self._wait_flow(job_id, timeout, poll_interval, request_timeout))

    def get_frame(self, job_id: str, name: str, *, timeout: Timeout = None) -> bytes:
        """A rendered key-frame strip (PNG bytes) named in the job's result."""
        return self._run(self._flow(ops.get_frame(job_id, name), timeout))

    # ---- skills and health ---------------------------------------------------------------
    def list_skills(self, *, timeout: Timeout = None) -> list[Skill]:
        return self._run(self._flow(ops.list_skills(), timeout))

    def get_skill(self, name: str, *, timeout: Timeout = None) -> Skill:
        return self._run(self._flow(ops.get_skill(name), timeout))

    def live(self, *, timeout: Timeout = None) -> Health:
        return self._run(self._flow(ops.live(), timeout))

    def ready(self, *, timeout: Timeout = None) -> Readiness:
        return self._run(self._flow(ops.ready(), timeout))

    def metrics(self, *, timeout: Timeout = None) -> str:
        """Prometheus text exposition."""
        return self._run(self._flow(ops.metrics(), timeout))

    # ---- lifetime ------------------------------------------------------------------------
    def close(self) -> None:
        if self._owns_http:
            self._http.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


class AsyncClient(_Base):
    """The asyncio twin of ``Client``: the same methods, awaited."""

    def __init__(
        self,
        base_url: str | None = None,
        *,
        timeout: Timeout = DEFAULT_TIMEOUT,
        max_retries: int = DEFAULT_MAX_RETRIES,
        retry: RetryPolicy | None = None,
        headers: Mapping[str, str] | None = None,
        http_client: httpx.AsyncClient | None = None,
    ) -> None:
        super().__init__(base_url, timeout, max_retries, retry, headers)
        self._owns_http = http_client is None
        self._http = http_client or httpx.AsyncClient()
        self._http.base_url = httpx.URL(self.settings.base_url)
        self._http.headers.update(self.settings.headers)

    async def _run(self, flow: Flow[T]) -> T:
        outcome: Outcome = None
        try:
            while True:
                action = flow.send(outcome)
                if isinstance(action, Sleep):
                    await asyncio.sleep(action.seconds)
                    outcome = None
                    continue
                try:
                    outcome = await self._http.send(build_request(self._http, action, self.settings.timeout))
                except httpx.TransportError as exc:
                    outcome = exc
        except StopIteration as stop:
            result: T = stop.value
            return result

    async def plan(
        self, plan: PlanLike, *, request_id: str | None = None, timeout: Timeout = None
    ) -> PlanResponse:
        return await self._run(self._flow(ops.plan(plan, request_id), timeout))

    async def verify(
        self,
        *,
        plan: PlanLike | None = None,
        candidates: Sequence[CandidateLike] | None = None,
        plan_id: str | None = None,
        top_k: int | None = None,
        seed: int = 0,
        max_attempts: int = 3,
        idempotency_key: str | None = None,
        timeout: Timeout = None,
    ) -> JobAccepted:
        operation = ops.verify(
            plan=plan,
            candidates=candidates,
            plan_id=plan_id,
            top_k=top_k,
            seed=seed,
            max_attempts=max_attempts,
            idempotency_key=idempotency_key,
        )
        return await self._run(self._flow(operation, timeout))

    async def get_job(self, job_id: str, *, timeout: Timeout = None) -> Job:
        return await self._run(self._flow(ops.get_job(job_id), timeout))

    async def wait_for_job(
        self,
        job_id: str,
        *,
        timeout: float = 600.0,
        poll_interval: float = 1.0,
        request_timeout: Timeout = None,
    ) -> Job:
        return await self._run(self._wait_flow(job_id, timeout, poll_interval, request_timeout))

    async def get_frame(self, job_id: str, name: str, *, timeout: Timeout = None) -> bytes:
        return await self._run(self._flow(ops.get_frame(job_id, name), timeout))

    async def list_skills(self, *, timeout: Timeout = None) -> list[Skill]:
        return await self._run(self._flow(ops.list_skills(), timeout))

    async def get_skill(self, name: str, *, timeout: Timeout = None) -> Skill:
        return await self._run(self._flow(ops.get_skill(name), timeout))

    async def live(self, *, timeout: Timeout = None) -> Health:
        return await self._run(self._flow(ops.live(), timeout))

    async def ready(self, *, timeout: Timeout = None) -> Readiness:
        return await self._run(self._flow(ops.ready(), timeout))

    async def metrics(self, *, timeout: Timeout = None) -> str:
        return await self._run(self._flow(ops.metrics(), timeout))

    async def close(self) -> None:
        if self._owns_http:
            await self._http.aclose()

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await self.close()
