"""The verification worker: claim a job, keep its lease alive, execute, record the result."""

from __future__ import annotations

import logging
import os
import socket
import threading
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gfc.pool import Pool, make_pool
from service.jobs import JobRecord, JobStore
from service.verification import VERIFY_KIND, verify_payload

log = logging.getLogger("gfc.worker")
Handler = Callable[[JobRecord], dict[str, Any]]


def worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}:{uuid.uuid4().hex[:6]}"


class Worker:
    """Processes jobs one at a time. A heartbeat thread renews the lease every ``lease_s / 3``;
    if this process dies, the lease runs out and another worker takes the job over."""

    def __init__(
        self,
        store: JobStore,
        handlers: dict[str, Handler],
        name: str | None = None,
        lease_s: float = 30.0,
        poll_s: float = 0.5,
    ) -> None:
        self.store = store
        self.handlers = handlers
        self.name = name or worker_name()
        self.lease_s = lease_s
        self.poll_s = poll_s

    def run_once(self) -> JobRecord | None:
        """Claim and process one job; None when there was nothing to do."""
        job = self.store.claim(self.name, self.lease_s)
        if job is None:
            return None
        stop = threading.Event()
        beat = threading.Thread(target=self._heartbeat, args=(job.id, stop), daemon=True)
        beat.start()
        try:
            handler = self.handlers.get(job.kind)
            if handler is None:
                self.store.fail(job.id, self.name, f"no handler for job kind {job.kind!r}", retry=False)
            else:
                result = handler(job)
                if not self.store.complete(job.id, self.name, result):
                    log.warning("job %s: lease lost before completion; result discarded", job.id)
        except Exception as exc:  # the job failed, not the worker: record it and go on
            log.exception("job %s failed", job.id)
            self.store.fail(job.id, self.name, f"{type(exc).__name__}: {exc}")
        finally:
            stop.set()
            beat.join()
        return self.store.get(job.id)

    def _heartbeat(self, job_id: str, stop: threading.Event) -> None:
        while not stop.wait(self.lease_s / 3):
            if not self.store.heartbeat(job_id, self.name, self.lease_s):
                return

    def run_forever(self, stop: threading.Event | None = None, parent_pid: int | None = None) -> None:
        """Poll until ``stop`` is set, or (``parent_pid``) until the parent process is gone: an
        embedded worker must not outlive the service that started it."""
        stop = stop or threading.Event()
        log.info("worker %s polling for jobs", self.name)
        while not stop.is_set():
            if parent_pid is not None and os.getppid() != parent_pid:
                log.info("worker %s: parent %d is gone, stopping", self.name, parent_pid)
                return
            if self.run_once() is None:
                stop.wait(self.poll_s)


def verification_worker(
    store: JobStore,
    data_dir: Path,
    processes: int = 1,
    lease_s: float = 30.0,
    pool: Pool | None = None,
    ray_address: str | None = None,
) -> Worker:
    frames_root = data_dir / "renders"
    chosen = pool or make_pool(ray_address, processes)

    def verify(job: JobRecord) -> dict[str, Any]:
        return verify_payload(job.payload, chosen, frames_root, job.id)

    return Worker(store, {VERIFY_KIND: verify}, lease_s=lease_s)
