"""One interface for fanning simulation work out: ``pool.map(fn, items)``.

Local processes by default (on this 2-core machine a process pool beat Ray: DESIGN.md).
Functions and items must be picklable by the standard library's ``multiprocessing`` (module
level functions, plain data); results come back in order.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor
from typing import Protocol, TypeVar

T = TypeVar("T")
R = TypeVar("R")


class Pool(Protocol):
    def map(self, fn: Callable[[T], R], items: Iterable[T]) -> list[R]: ...


class InlinePool:
    """Runs everything in this process (one item at a time): debugging and tiny jobs."""

    def map(self, fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
        return [fn(item) for item in items]


class LocalPool:
    """A process pool; ``spawn`` so no simulator or torch state leaks into the children."""

    def __init__(self, processes: int = 2) -> None:
        if processes < 1:
            raise ValueError(f"a pool needs at least one process, got {processes}")
        self.processes = processes

    def map(self, fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
        work = list(items)
        if len(work) <= 1 or self.processes == 1:
            return InlinePool().map(fn, work)
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=min(self.processes, len(work)), mp_context=context) as pool:
            return list(pool.map(fn, work))
