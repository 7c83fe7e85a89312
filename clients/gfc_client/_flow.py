"""The request logic once, without I/O: generators that yield what to do (send a request, sleep)
and receive what happened. ``Client`` and ``AsyncClient`` only drive them (see ``_drivers``)."""

from __future__ import annotations

import time
from collections.abc import Callable, Generator, Mapping
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

import httpx

from gfc_client._errors import APIError, JobWaitTimeout, connection_error, status_error
from gfc_client._retry import RetryPolicy
from gfc_client._retry_after import retry_after_seconds
from gfc_client.models import Job

T = TypeVar("T")


@dataclass(frozen=True)
class Operation(Generic[T]):
    """One API call: the request to send and how to read a successful answer."""

    method: str
    path: str
    parse: Callable[[httpx.Response], T]
    json: Any = None
    headers: Mapping[str, str] = field(default_factory=dict)
    ok: frozenset[int] = frozenset({200})


@dataclass(frozen=True)
class Send:
    method: str
    path: str
    json: Any
    headers: Mapping[str, str]
    timeout: float | httpx.Timeout | None


@dataclass(frozen=True)
class Sleep:
    seconds: float


Action = Send | Sleep
Outcome = httpx.Response | httpx.TransportError | None  # None answers a Sleep
Flow = Generator[Action, Outcome, T]


def call(operation: Operation[T], policy: RetryPolicy, timeout: float | httpx.Timeout | None) -> Flow[T]:
    """Send ``operation``; on a retryable failure wait (backoff with jitter, or Retry-After) and
    send the same request again (same headers, so the same idempotency key), at most
    ``policy.max_retries`` times."""
    send = Send(operation.method, operation.path, operation.json, operation.headers, timeout)
    retry = 0
    while True:
        outcome = yield send
        error: APIError
        retry_after = None
        if isinstance(outcome, httpx.Response):
            if outcome.status_code in operation.ok:
                return operation.parse(outcome)
            error = status_error(outcome)
            retry_after = retry_after_seconds(outcome.headers)
        elif isinstance(outcome, httpx.TransportError):
            error = connection_error(outcome)
        else:
            raise TypeError(f"a Send must be answered with a response or a transport error, not {outcome!r}")
        if retry >= policy.max_retries or not policy.should_retry(error):
            raise error
        yield Sleep(policy.delay(retry, retry_after))
        retry += 1


def wait_for_job(
    get_job: Operation[Job],
    policy: RetryPolicy,
    request_timeout: float | httpx.Timeout | None,
    timeout: float,
    poll_interval: float,
    clock: Callable[[], float] = time.monotonic,
) -> Flow[Job]:
    """Poll until the job succeeds or fails; raise ``JobWaitTimeout`` after ``timeout`` seconds."""
    if timeout < 0 or poll_interval <= 0:
        raise ValueError("timeout must be >= 0 and poll_interval > 0")
    start = clock()
    while True:
        job = yield from call(get_job, policy, request_timeout)
        if job.done:
            return job
        remaining = start + timeout - clock()
        if remaining <= 0:
            raise JobWaitTimeout(job, clock() - start)
        yield Sleep(min(poll_interval, remaining))
