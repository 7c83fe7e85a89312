"""The simulation pool interface: local processes and a (local) Ray cluster give the same results."""

from __future__ import annotations

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
