"""The simulation pool interface: local processes and a (local) Ray cluster give the same results."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from gfc.pool import InlinePool, LocalPool, RayPool, make_pool


def square_plus_pid(x: int) -> tuple[int, int]:
    import os

    return x * x, os.getpid()


def test_local_pool_keeps_order_and_uses_other_processes() -> None:
    import os

    results = LocalPool(2).map(square_plus_pid, range(6))
    assert [r[0] for r in results] == [0, 1, 4, 9, 16, 25]
    assert all(pid != os.getpid() for _, pid in results)
    assert InlinePool().map(square_plus_pid, [3])[0][0] == 9


def test_make_pool_defaults_to_local_processes() -> None:
    assert isinstance(make_pool(None, 2), LocalPool)
    with pytest.raises(ValueError, match="at least one process"):
        LocalPool(0)


@pytest.mark.slow
def test_ray_pool_runs_tasks_on_a_local_cluster() -> None:
    pool = make_pool("local")
    assert isinstance(pool, RayPool)
    results = pool.map(square_plus_pid, range(5))
    assert [r[0] for r in results] == [0, 1, 4, 9, 16]


def _sleep(seconds: float) -> float:
    import time

    time.sleep(seconds)
    return seconds


def _pid_after(seconds: float) -> int:
    """The worker's pid, after a pause long enough for both workers to get items."""
    _sleep(seconds)
    return os.getpid()


# A parent with two kept-alive workers: it prints their pids, leaves them a long queue and waits.
_ORPHANING_PARENT = """
import sys, threading
from gfc.pool import LocalPool
from tests.test_pool import _pid_after, _sleep
pool = LocalPool(2, keep_alive=True)
print(" ".join(str(p) for p in sorted(set(pool.map(_pid_after, [0.3] * 4)))), flush=True)
threading.Thread(target=pool.map, args=(_sleep, [120.0] * 4), daemon=True).start()
sys.stdin.read()
"""


def test_workers_die_when_the_parent_is_killed() -> None:
    """SIGTERM on a run's parent takes its pool workers with it (they used to keep simulating)."""
    parent = subprocess.Popen(
        [sys.executable, "-c", _ORPHANING_PARENT],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=Path(__file__).resolve().parents[1],
    )
    assert parent.stdout is not None
    workers = [int(p) for p in parent.stdout.readline().split()]
    assert workers and all(_alive(pid) for pid in workers)
    parent.send_signal(signal.SIGTERM)
    parent.wait(timeout=30)
    deadline = time.monotonic() + 30
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(pid) for pid in workers), "a worker outlived its killed parent"


def test_kept_alive_workers_outlive_the_thread_that_started_them() -> None:
    """gfc bench tasks maps from one short-lived thread per task; the workers those threads started
    must serve the next task (with PR_SET_PDEATHSIG they died with the first thread)."""
    with LocalPool(2, keep_alive=True) as pool:
        first: list[list[tuple[int, int]]] = []
        starter = threading.Thread(target=lambda: first.append(pool.map(square_plus_pid, range(4))))
        starter.start()
        starter.join()
        time.sleep(0.5)  # PDEATHSIG's SIGTERM arrives right after the thread exits
        again = pool.map(square_plus_pid, range(4))
    assert [r[0] for r in again] == [0, 1, 4, 9]
    assert [r[0] for r in first[0]] == [0, 1, 4, 9]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # A dead child not yet reaped by its (also dead) parent is a zombie: count it as gone.
    stat = Path(f"/proc/{pid}/stat")
    return not (stat.exists() and stat.read_text().split(") ", 1)[1].startswith("Z"))
