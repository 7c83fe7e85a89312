"""When to retry and how long to wait: exponential backoff with jitter, or the server's Retry-After."""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass, field

from gfc_client._errors import APIConnectionError, APIError, APIStatusError, ConflictError

RETRY_STATUSES = frozenset({408, 429, 500, 502, 503, 504})


@dataclass(frozen=True)
class RetryPolicy:
    max_retries: int = 2  # attempts after the first
    initial_delay: float = 0.5  # seconds before the first retry (before jitter)
    max_delay: float = 8.0  # backoff cap
    max_retry_after: float = 60.0  # longest Retry-After we honour; longer ones are capped
    jitter: Callable[[], float] = field(default=random.random, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.max_retries < 0:
            raise ValueError(f"max_retries must be >= 0, got {self.max_retries}")
        if self.initial_delay < 0 or self.max_delay < 0:
            raise ValueError("retry delays must be >= 0")

    def should_retry(self, error: APIError) -> bool:
        """Connection errors, timeouts, 408, 429 and 5xx; never 409 (an idempotency conflict)."""
        if isinstance(error, ConflictError):
            return False
        if isinstance(error, APIConnectionError):
            return True
        return isinstance(error, APIStatusError) and error.status_code in RETRY_STATUSES

    def delay(self, retry: int, retry_after: float | None) -> float:
        """Seconds to wait before retry number ``retry`` (0-based)."""
        if retry_after is not None:
            return min(retry_after, self.max_retry_after)
        backoff = min(self.initial_delay * 2.0**retry, self.max_delay)
        return backoff * (1.0 - 0.25 * self.jitter())  # up to 25 % shorter: spread the herd
