"""One interface for fanning simulation work out: ``pool.map(fn, items)``.

Local processes by default (on this 2-core machine a process pool beat Ray: DESIGN.md); a Ray
cluster when an address is configured (``pip install 'gfc[ray]'``). Functions and items must be
module-level functions and plain data (they cross process boundaries through the standard
library's serialisation, as multiprocessing and Ray require); results come back in order.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
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


def make_pool(ray_address: str | None = None, processes: int = 2, keep_alive: bool = False) -> Pool:
    """Ray when an address is given (``auto``, ``ray://host:10001``, ``local`` for an
    in-process cluster), else local processes (kept up between calls with ``keep_alive``;
    the caller then closes the pool)."""
    if ray_address:
        return RayPool(None if ray_address == "local" else ray_address)
    return LocalPool(processes, keep_alive=keep_alive)


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


PARENT_POLL_S = 0.5  # how often a worker checks that its parent is still alive


def die_with_parent(parent_pid: int) -> None:
    """Worker initializer: exit once the parent process is gone.

    Without it, killing a long run (``kill`` on ``gfc bench tasks`` or ``gfc collect``) left its
    kept-alive workers simulating their queued items for many minutes, holding the CPUs. A daemon
    thread polls the parent's pid (an orphan is re-parented, so ``getppid`` changes).

    Until session 12 this was ``prctl(PR_SET_PDEATHSIG)``, which fires when the *thread* that
    forked the worker exits, not the process: ``gfc bench tasks`` hands ``pool.map`` to a thread
    per task, so the kept-alive workers were killed at the first task change ("a child process
    terminated abruptly" on every multi-task run)."""

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, name="die-with-parent", daemon=True).start()


class LocalPool:
    """A process pool; ``spawn`` so no simulator or torch state leaks into the children.

    By default each ``map`` starts fresh processes (nothing carries over between calls). With
    ``keep_alive=True`` the processes stay up between calls until ``close()``: a data collection
    of many shards then pays the few seconds of interpreter and torch start-up once, not per shard.
    """

    def __init__(self, processes: int = 2, keep_alive: bool = False) -> None:
        if processes < 1:
            raise ValueError(f"a pool needs at least one process, got {processes}")
        self.processes = processes
        self.keep_alive = keep_alive
        self._executor: ProcessPoolExecutor | None = None

    def _start(self, workers: int) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=die_with_parent,
            initargs=(os.getpid(),),
        )

    def map(self, fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
        work = list(items)
        if len(work) <= 1 or self.processes == 1:
            return InlinePool().map(fn, work)
        if self.keep_alive:
            if self._executor is None:
                self._executor = self._start(self.processes)
            return list(self._executor.map(fn, work))
        with self._start(min(self.processes, len(work))) as pool:
            return list(pool.map(fn, work))

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown()
            self._executor = None

    def __enter__(self) -> LocalPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
