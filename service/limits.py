"""Admission control: a bounded number of plans in the service at once; beyond it, 503."""

from __future__ import annotations


class Overloaded(Exception):
    """Raised when the service cannot take another plan now; the caller should retry later."""


class Admission:
    """``async with admission:`` lets at most ``capacity`` requests in at once (running in a
    sampling batch or waiting for one) and refuses the rest (``Overloaded``) instead of letting
    latency grow without bound. How many sample at once is the batcher's business."""

    def __init__(self, capacity: int) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be at least 1, got {capacity}")
        self.capacity = capacity
        self._inside = 0

    @property
    def in_flight(self) -> int:
        return self._inside

    async def __aenter__(self) -> Admission:
        if self._inside >= self.capacity:
            raise Overloaded(f"{self._inside} plans running or queued (limit {self.capacity})")
        self._inside += 1
        return self

    async def __aexit__(self, *exc: object) -> None:
        self._inside -= 1
