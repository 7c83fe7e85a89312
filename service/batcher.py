"""Micro-batching: plans that arrive within a short window share one sampling run.

Every sampling step is then one network call for all of them (see ``gfc.planner.plan_many``).
Requests that disagree on sampling settings (steps, sampler, correctors, compensation) go into
separate batches. A window of 0 turns batching off.
"""

from __future__ import annotations

import asyncio
import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import torch

from gfc.plan.graph import CompiledPlan
from gfc.plan.schema import Options
from gfc.planner.library import SkillLibrary
from gfc.planner.planner import PlanResult, batch_key, plan_many


@dataclass
class _Pending:
    plan: CompiledPlan
    options: Options
    future: asyncio.Future[PlanResult] = field(repr=False)


class PlanBatcher:
    def __init__(
        self,
        library: SkillLibrary,
        window_s: float,
        max_batch: int,
        workers: int,
        torch_threads: int = 1,
        on_batch: Callable[[int], Any] | None = None,
    ) -> None:
        self.library = library
        self.window_s = window_s
        self.max_batch = max_batch
        self.torch_threads = torch_threads
        self.on_batch = on_batch
        self._queue: asyncio.Queue[_Pending] | None = None
        self._slots = asyncio.Semaphore(workers)
        self._task: asyncio.Task[None] | None = None
        self._running: set[asyncio.Task[None]] = set()

    async def plan(self, plan: CompiledPlan, options: Options) -> PlanResult:
        if self._queue is None:  # created lazily, inside the server's event loop
            self._queue = asyncio.Queue()
            self._task = asyncio.create_task(self._collect())
        future: asyncio.Future[PlanResult] = asyncio.get_running_loop().create_future()
        await self._queue.put(_Pending(plan, options, future))
        return await future

    async def _collect(self) -> None:
        assert self._queue is not None
        while True:
            first = await self._queue.get()
            batch = [first]
            deadline = time.monotonic() + self.window_s
            while len(batch) < self.max_batch:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    break
                try:
                    batch.append(await asyncio.wait_for(self._queue.get(), remaining))
                except TimeoutError:
                    break
            groups: dict[tuple[Any, ...], list[_Pending]] = defaultdict(list)
            for pending in batch:
                groups[batch_key(pending.options)].append(pending)
            for group in groups.values():
                await self._slots.acquire()
                task = asyncio.create_task(self._run(group))
                self._running.add(task)
                task.add_done_callback(self._running.discard)

    async def _run(self, group: list[_Pending]) -> None:
        try:
            if self.on_batch is not None:
                self.on_batch(len(group))
            requests = [(p.plan, p.options) for p in group]
            results = await asyncio.to_thread(self._plan, requests)
            for pending, result in zip(group, results, strict=True):
                if not pending.future.done():
                    pending.future.set_result(result)
        except Exception as exc:  # every request of the batch gets the error
            for pending in group:
                if not pending.future.done():
                    pending.future.set_exception(exc)
        finally:
            self._slots.release()

    def _plan(self, requests: list[tuple[CompiledPlan, Options]]) -> list[PlanResult]:
        torch.set_num_threads(self.torch_threads)
        return plan_many(requests, self.library)
