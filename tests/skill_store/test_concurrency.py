"""Readers never see a partial version; concurrent publishers never share a version number."""

from __future__ import annotations

import multiprocessing
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from multiprocessing.synchronize import Barrier as BarrierType
from pathlib import Path

import torch

from skill_store import SkillStore
from tests.skill_store.conftest import random_model


def test_a_reader_never_sees_a_partial_version(store: SkillStore) -> None:
    models = [random_model(seed) for seed in range(8)]
    done = threading.Event()
    problems: list[str] = []
    loads = 0

    def read_while_publishing() -> None:
        nonlocal loads
        while not done.is_set():
            for version in store.versions("pick.hammer"):
                try:
                    loaded = store.load(f"pick.hammer@{version}")
                except Exception as error:  # any failure is a partial version seen
                    problems.append(f"@{version}: {error!r}")
                    continue
                loads += 1
                # Version v holds model v - 1: a reader never gets another version's weights.
                if not torch.equal(loaded.network.enc_w, models[version - 1].network.enc_w):
                    problems.append(f"@{version}: wrong weights")

    reader = threading.Thread(target=read_while_publishing)
    reader.start()
    try:
        for model in models:
            store.publish("pick.hammer", model)
    finally:
        done.set()
        reader.join()
    assert problems == []
    assert loads > 0
    assert store.versions("pick.hammer") == tuple(range(1, 9))


def test_concurrent_publishers_get_distinct_versions(store: SkillStore) -> None:
    model = random_model(0)
    start = threading.Barrier(8)

    def publish_twice(_: int) -> list[int]:
        start.wait()  # all publishers race for the same next number
        return [store.publish("pick.hammer", model) for _ in range(2)]

    switch_interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # switch threads often, so races happen if they can
    try:
        with ThreadPoolExecutor(max_workers=8) as pool:
            versions = [v for vs in pool.map(publish_twice, range(8)) for v in vs]
    finally:
        sys.setswitchinterval(switch_interval)
    assert sorted(versions) == list(range(1, 17))
    assert store.versions("pick.hammer") == tuple(range(1, 17))
    assert all(result.ok for result in store.verify())


def _publish_from_another_process(
    location: str, seed: int, start: BarrierType, results: multiprocessing.Queue[int]
) -> None:
    store = SkillStore(location)
    model = random_model(seed)
    start.wait()
    for _ in range(3):
        results.put(store.publish("pick.hammer", model))


def test_concurrent_processes_get_distinct_versions_on_a_local_folder(tmp_path: Path) -> None:
    # Processes share nothing but the filesystem: only exclusive creation keeps numbers apart.
    location = str(tmp_path / "store")
    context = multiprocessing.get_context("fork")
    results: multiprocessing.Queue[int] = context.Queue()
    start = context.Barrier(4)
    workers = [
        context.Process(target=_publish_from_another_process, args=(location, s, start, results))
        for s in range(4)
    ]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(timeout=60)
    assert [w.exitcode for w in workers] == [0, 0, 0, 0]
    versions = sorted(results.get(timeout=5) for _ in range(12))
    assert versions == list(range(1, 13))
    assert SkillStore(location).versions("pick.hammer") == tuple(range(1, 13))
