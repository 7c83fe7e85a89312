"""One interface for fanning simulation work out: ``pool.map(fn, items)``.

Local processes by default (on this 2-core machine a process pool beat Ray: DESIGN.md); a Ray
cluster when an address is configured (``pip install 'gfc[ray]'``). Functions and items must be
module-level functions and plain data (they cross process boundaries through the standard
library's serialisation, as multiprocessing and Ray require); results come back in order.
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


def make_pool(ray_address: str | None = None, processes: int = 2) -> Pool:
    """Ray when an address is given (``auto``, ``ray://host:10001``, ``local`` for an
    in-process cluster), else local processes."""
    if ray_address:
        return RayPool(None if ray_address == "local" else ray_address)
    return LocalPool(processes)


class RayPool:
    """Tasks on a Ray cluster: one task per item, results gathered in order."""

    def __init__(self, address: str | None = None, num_cpus: int | None = None) -> None:
        try:
            import ray
        except ImportError:
            raise RuntimeError(
                "Ray is not installed: pip install 'gfc[ray]' (or unset GFC_RAY_ADDRESS)"
            ) from None
        self._ray = ray
        if not ray.is_initialized():
            ray.init(
                address=address,
                num_cpus=num_cpus if address is None else None,
                include_dashboard=False,
                log_to_driver=False,
                configure_logging=False,
            )

    def map(self, fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
        task = self._ray.remote(fn)
        return list(self._ray.get([task.remote(item) for item in items]))


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
