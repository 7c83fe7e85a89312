"""A real uvicorn server on a free port, serving an app around an in-memory skill library."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import httpx
import pytest
import uvicorn

from gfc.examples import load_example
from gfc.plan import compile_plan
from gfc.planner.library import InMemoryLibrary, random_library
from service.catalog import InMemoryCatalog
from service.main import create_app
from service.settings import Settings


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def running_server(settings: Settings, library: InMemoryLibrary) -> Iterator[str]:
    port = free_port()
    app = create_app(settings, library, InMemoryCatalog(library))
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        if time.monotonic() > deadline:
            raise RuntimeError("uvicorn did not start within 30 s")
        time.sleep(0.02)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=10)


@pytest.fixture(scope="module")
def library() -> InMemoryLibrary:
    """Randomly initialised DiT models for the example plans' skills (no training needed to
    exercise the HTTP surface; success in simulation is another issue's test)."""
    models = {}
    for name in ("hammer_place", "hammer_nail"):
        models.update(random_library(compile_plan(load_example(name))).models)
    return InMemoryLibrary(models)


@pytest.fixture(scope="module")
def server(library: InMemoryLibrary) -> Iterator[str]:
    with running_server(Settings(max_body_bytes=200_000), library) as url:
        yield url


@pytest.fixture
def client(server: str) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=server, timeout=60) as c:
        yield c


ServerFactory = Callable[..., object]
