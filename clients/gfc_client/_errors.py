"""Errors by cause: the server answered with an error status, or it could not be reached.

::

    GFCError
    ├── APIError
    │   ├── APIStatusError            (any error status; .status_code, .error, .detail, .request_id)
    │   │   ├── BadRequestError       (400, and the subclasses below)
    │   │   │   ├── ConflictError             (409: idempotency key reused with another body)
    │   │   │   ├── RequestTooLargeError      (413)
    │   │   │   └── UnprocessableEntityError  (422: invalid plan; .detail says where)
    │   │   ├── AuthenticationError   (401)
    │   │   ├── NotFoundError         (404)
    │   │   ├── RateLimitError        (429, or 503 "overloaded"; .retry_after)
    │   │   └── InternalServerError   (5xx)
    │   └── APIConnectionError        (no answer: refused, reset, DNS)
    │       └── APITimeoutError
    └── JobWaitTimeout               (wait_for_job ran out of time; .job is the last state seen)
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import httpx

from gfc_client._retry_after import retry_after_seconds
from gfc_client.models import Issue

if TYPE_CHECKING:
    from gfc_client.models import Job


class GFCError(Exception):
    """Base of every error this SDK raises."""


class APIError(GFCError):
    def __init__(self, message: str, *, request: httpx.Request | None) -> None:
        super().__init__(message)
        self.message = message
        self.request = request


class APIStatusError(APIError):
    """The server answered with an error status. ``detail`` lists problems with their location."""

    def __init__(self, message: str, *, response: httpx.Response, body: Any) -> None:
        super().__init__(message, request=response.request)
        self.response = response
        self.status_code = response.status_code
        self.body = body
        self.request_id: str | None = response.headers.get("x-request-id")
        self.error: str = ""
        self.detail: list[Issue] = []
        if isinstance(body, dict):
            self.error = str(body.get("error", ""))
            raw = body.get("detail")
            if isinstance(raw, list):
                self.detail = [Issue.model_validate(d) for d in raw if isinstance(d, dict)]
            elif isinstance(raw, str):  # FastAPI's default shape
                self.error = self.error or raw


class BadRequestError(APIStatusError):
    pass


class ConflictError(BadRequestError):
    pass


class RequestTooLargeError(BadRequestError):
    pass


class UnprocessableEntityError(BadRequestError):
    pass


class AuthenticationError(APIStatusError):
    pass


class NotFoundError(APIStatusError):
    pass


class RateLimitError(APIStatusError):
    """Too many requests, or the service is overloaded: retry after ``retry_after`` seconds."""

    @property
    def retry_after(self) -> float | None:
        return retry_after_seconds(self.response.headers)


class InternalServerError(APIStatusError):
    pass


class APIConnectionError(APIError):
    def __init__(
        self, message: str = "could not reach the gfc service", *, request: httpx.Request | None
    ) -> None:
        super().__init__(message, request=request)


class APITimeoutError(APIConnectionError):
    def __init__(self, *, request: httpx.Request | None) -> None:
        super().__init__(
            "the request timed out (pass timeout=... to wait longer, or check the service's load)",
            request=request,
        )


class JobWaitTimeout(GFCError, TimeoutError):
    """``wait_for_job`` gave up; the job may still finish (poll it again with ``get_job``)."""

    def __init__(self, job: Job, waited_s: float) -> None:
        super().__init__(
            f"job {job.id} is still {job.status.value} after {waited_s:.1f} s; "
            "call wait_for_job again with a longer timeout, or get_job later"
        )
        self.job = job


_BY_STATUS: dict[int, type[APIStatusError]] = {
    400: BadRequestError,
    401: AuthenticationError,
    404: NotFoundError,
    409: ConflictError,
    413: RequestTooLargeError,
    422: UnprocessableEntityError,
    429: RateLimitError,
}


def _body(response: httpx.Response) -> Any:
    try:
        return response.json()
    except ValueError:
        return response.text


def _message(response: httpx.Response, body: Any) -> str:
    text = f"{response.status_code} {response.reason_phrase}"
    if isinstance(body, dict):
        error = body.get("error") or body.get("detail")
        if isinstance(error, str) and error:
            text += f": {error}"
        issues = body.get("detail")
        if isinstance(issues, list):
            text += "".join(
                f"\n  {d.get('loc', '?')}: {d.get('message', '')}" for d in issues if isinstance(d, dict)
            )
    elif body:
        text += f": {str(body)[:200]}"
    return text


def status_error(response: httpx.Response) -> APIStatusError:
    """The exception for an error response, chosen by status (and for 503, by cause)."""
    body = _body(response)
    status = response.status_code
    cls = _BY_STATUS.get(status)
    if cls is None:
        overloaded = isinstance(body, dict) and body.get("error") == "overloaded"
        if status == 503 and (overloaded or "retry-after" in response.headers):
            cls = RateLimitError
        elif status >= 500:
            cls = InternalServerError
        elif 400 <= status < 500:
            cls = BadRequestError if status == 400 else APIStatusError
        else:
            cls = APIStatusError
    return cls(_message(response, body), response=response, body=body)


def connection_error(exc: httpx.TransportError) -> APIConnectionError:
    request: httpx.Request | None
    try:
        request = exc.request
    except RuntimeError:  # raised before a request was attached
        request = None
    if isinstance(exc, httpx.TimeoutException):
        return APITimeoutError(request=request)
    where = f" at {request.url}" if request is not None else ""
    return APIConnectionError(
        f"could not reach the gfc service{where}: {exc} (is `gfc serve` running there?)", request=request
    )
