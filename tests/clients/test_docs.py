"""Every Python example in docs/sdk.md runs against a real service (a test thread plays the
verification worker)."""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.clients.conftest import VERIFIED, Service, write_frame

DOC = Path(__file__).resolve().parents[2] / "docs" / "sdk.md"
BLOCKS = re.findall(r"^```python\n(.*?)^```", DOC.read_text(), flags=re.MULTILINE | re.DOTALL)


@pytest.fixture
def worker(service: Service) -> Iterator[list[str]]:
    stop = threading.Event()
    done: list[str] = []

    def work() -> None:
        while not stop.is_set():
            job = service.jobs.claim("docs-worker", lease_s=30)
            if job is None:
                time.sleep(0.05)
                continue
            write_frame(service.settings, job.id, "rank0.png")
            service.jobs.complete(job.id, "docs-worker", VERIFIED)
            done.append(job.id)

    thread = threading.Thread(target=work)
    thread.start()
    try:
        yield done
    finally:
        stop.set()
        thread.join()


def test_the_guide_has_examples() -> None:
    assert len(BLOCKS) >= 6


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_example_runs(
    index: int,
    service: Service,
    worker: list[str],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setenv("GFC_URL", service.url)
    code = compile(BLOCKS[index], f"{DOC.name} example {index + 1}", "exec")
    exec(code, {"__name__": "__main__"})
    assert capsys.readouterr().out.strip()  # every example prints what it got
