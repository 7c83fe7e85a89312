"""Admission control: a bounded number of plans run, a bounded number wait, the rest get 503."""

from __future__ import annotations

import asyncio


class Overloaded(Exception):
    """Raised when the service cannot take another plan now; the caller should retry later."""


class Admission:
    """``async with admission:`` runs at most ``running`` bodies at once, queues at most ``waiting``
    more, and refuses (``Overloaded``) beyond that instead of letting latency grow without bound."""

    def __init__(self, running: int, waiting: int) -> None:
        self._slots = asyncio.Semaphore(running)
        self._capacity = running + waiting
        self._inside = 0

    @property
    def in_flight(self) -> int:
        return self._inside

    async def __aenter__(self) -> Admission:
        if self._inside >= self._capacity:
            raise Overloaded(f"{self._inside} plans running or queued (limit {self._capacity})")
        self._inside += 1
        try:
            await self._slots.acquire()
        except BaseException:
            self._inside -= 1
            raise
        return self

    async def __aexit__(self, *exc: object) -> None:
        self._slots.release()
        self._inside -= 1
