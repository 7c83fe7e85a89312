"""Error classes by status, retries (Retry-After, backoff, idempotency keys) and timeouts, over
real HTTP against a scripted server."""

from __future__ import annotations

import email.utils
import time
from typing import Any

import pytest
from gfc_client import (
    APIConnectionError,
    APIStatusError,
    APITimeoutError,
    AuthenticationError,
    BadRequestError,
    Client,
    ConflictError,
    InternalServerError,
    NotFoundError,
    RateLimitError,
    RequestTooLargeError,
    RetryPolicy,
    UnprocessableEntityError,
)
from gfc_client._retry_after import retry_after_seconds

from gfc.examples import load_example
from tests.clients.conftest import Reply, Script, free_port

OVERLOADED = {"error": "overloaded", "detail": [{"loc": "service", "message": "busy"}], "request_id": "r"}


def plan_response() -> dict[str, Any]:
    step = {"step": 0, "skill": "pick", "model": "pick.hammer", "action": [0.0] * 9}
    candidate = {"rank": 0, "cost": 0.5, "steps": [step], "nodes": {}, "residuals": []}
    return {"request_id": "r", "plan_id": "p", "candidates": [candidate], "models": {}, "timing": {}}


def no_wait(max_retries: int = 2) -> RetryPolicy:
    return RetryPolicy(max_retries=max_retries, initial_delay=0.01, max_delay=0.02)


@pytest.mark.parametrize(
    ("status", "body", "headers", "error"),
    [
        (400, {"error": "bad"}, {}, BadRequestError),
        (401, {"error": "needs a token"}, {}, AuthenticationError),
        (404, {"error": "no skill"}, {}, NotFoundError),
        (409, {"error": "key reused"}, {}, ConflictError),
        (413, {"error": "too large"}, {}, RequestTooLargeError),
        (
            422,
            {"error": "invalid plan", "detail": [{"loc": "scene", "message": "m"}]},
            {},
            UnprocessableEntityError,
        ),
        (429, {"error": "slow down"}, {}, RateLimitError),
        (503, OVERLOADED, {"Retry-After": "0"}, RateLimitError),
        (500, {"error": "boom"}, {}, InternalServerError),
        (503, {"error": "skill version unavailable"}, {}, InternalServerError),
        (418, "teapot", {}, APIStatusError),
    ],
)
def test_each_status_raises_its_error(
    script: Script, status: int, body: Any, headers: dict[str, str], error: type[Exception]
) -> None:
    script.then(Reply(status, body, headers))
    with Client(script.url, max_retries=0) as client, pytest.raises(error) as caught:
        client.get_skill("x")
    raised = caught.value
    assert type(raised) is error
    assert isinstance(raised, APIStatusError) and raised.status_code == status
    assert str(status) in str(raised)


def test_subclasses_group_by_cause() -> None:
    for cls in (ConflictError, RequestTooLargeError, UnprocessableEntityError):
        assert issubclass(cls, BadRequestError)
    assert issubclass(APITimeoutError, APIConnectionError)


def test_503_with_retry_after_is_retried_after_that_long(script: Script) -> None:
    script.then(
        Reply(503, OVERLOADED, {"Retry-After": "1"}),
        Reply(503, OVERLOADED, {"Retry-After": "1"}),
        Reply(200, plan_response()),
    )
    with Client(script.url, max_retries=2) as client:
        response = client.plan(load_example("hammer_place"))
    assert response.best.cost == 0.5
    assert len(script.seen) == 3
    gaps = [b.at - a.at for a, b in zip(script.seen, script.seen[1:], strict=False)]
    assert all(gap >= 0.95 for gap in gaps), gaps  # the server's Retry-After, not the 0.5 s backoff
    assert all(s.body == script.seen[0].body for s in script.seen)


def test_retries_give_up_with_the_last_error(script: Script) -> None:
    script.then(*[Reply(503, OVERLOADED, {"Retry-After": "0"})] * 2)
    with Client(script.url, max_retries=1) as client, pytest.raises(RateLimitError) as caught:
        client.list_skills()
    assert caught.value.retry_after == 0.0
    assert len(script.seen) == 2


def test_server_errors_are_retried_with_backoff_client_errors_are_not(script: Script) -> None:
    script.then(Reply(500, {"error": "boom"}), Reply(502, "bad gateway"), Reply(200, []))
    with Client(script.url, retry=no_wait()) as client:
        assert client.list_skills() == []
    assert len(script.seen) == 3
    script.then(Reply(422, {"error": "invalid"}), Reply(200, []))
    with Client(script.url, retry=no_wait()) as client, pytest.raises(UnprocessableEntityError):
        client.list_skills()
    assert len(script.seen) == 4  # one attempt only


def test_one_idempotency_key_across_the_retries_of_a_submission(script: Script) -> None:
    accepted = {"job_id": "j1", "status": "queued", "url": "/jobs/j1"}
    script.then(Reply(500, {"error": "boom"}), Reply(202, accepted), Reply(202, accepted))
    with Client(script.url, retry=no_wait()) as client:
        assert client.verify(plan_id="p").job_id == "j1"
        client.verify(plan_id="p")
    keys = [s.headers["idempotency-key"] for s in script.seen]
    assert keys[0] == keys[1]  # the retry is the same submission
    assert keys[2] != keys[0]  # a new call is a new submission
    assert len(keys[0]) == 32


def test_conflict_is_never_retried(script: Script) -> None:
    script.then(Reply(409, {"error": "key reused"}), Reply(202, {}))
    with Client(script.url, retry=no_wait()) as client, pytest.raises(ConflictError):
        client.verify(plan_id="p", idempotency_key="mine")
    assert [s.headers["idempotency-key"] for s in script.seen] == ["mine"]


def test_connection_refused_is_a_connection_error_after_retries() -> None:
    url = f"http://127.0.0.1:{free_port()}"  # nothing listens there
    start = time.monotonic()
    with Client(url, retry=no_wait(max_retries=2)) as client, pytest.raises(APIConnectionError) as caught:
        client.live()
    assert not isinstance(caught.value, APITimeoutError)
    assert "gfc serve" in str(caught.value)
    assert time.monotonic() - start < 5


def test_timeouts_per_client_and_per_call(script: Script) -> None:
    script.then(Reply(200, [], delay_s=0.6), Reply(200, [], delay_s=0.6))
    with Client(script.url, timeout=0.1, max_retries=0) as client:
        with pytest.raises(APITimeoutError):
            client.list_skills()
        assert client.list_skills(timeout=5.0) == []  # the per-call override wins
    script.then(Reply(200, [], delay_s=0.6))
    with Client(script.url, timeout=30.0, max_retries=0) as client, pytest.raises(APITimeoutError):
        client.list_skills(timeout=0.1)


def test_backoff_grows_is_capped_and_jittered() -> None:
    policy = RetryPolicy(initial_delay=0.5, max_delay=2.0, jitter=lambda: 1.0)
    assert [policy.delay(n, None) for n in range(4)] == [0.375, 0.75, 1.5, 1.5]
    assert RetryPolicy(jitter=lambda: 0.0).delay(0, None) == 0.5
    assert policy.delay(0, 120.0) == 60.0  # Retry-After honoured up to max_retry_after
    with pytest.raises(ValueError, match="max_retries"):
        RetryPolicy(max_retries=-1)


def test_retry_after_reads_seconds_and_http_dates() -> None:
    now = time.time()
    assert retry_after_seconds({"retry-after": "3"}) == 3.0
    assert retry_after_seconds({"retry-after": email.utils.formatdate(now + 10, usegmt=True)}, now=now) == (
        pytest.approx(10, abs=1.0)
    )
    assert retry_after_seconds({"retry-after": "soon"}) is None
    assert retry_after_seconds({}) is None


def test_base_url_is_checked_and_read_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(ValueError, match="http://"):
        Client("localhost:8000")
    monkeypatch.setenv("GFC_URL", "http://example.invalid:9/")
    with Client() as client:
        assert client.base_url == "http://example.invalid:9"
