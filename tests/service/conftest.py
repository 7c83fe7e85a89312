"""A real uvicorn server on a free port, serving an app around an in-memory skill library."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

import httpx
import pytest

from gfc.examples import load_example
from gfc.plan import compile_plan
from gfc.planner.library import InMemoryLibrary, random_library
from service.catalog import InMemoryCatalog
from service.local_server import serve_in_thread
from service.main import create_app
from service.settings import Settings


@contextmanager
def running_server(settings: Settings, library: InMemoryLibrary) -> Iterator[str]:
    with serve_in_thread(create_app(settings, library, InMemoryCatalog(library))) as url:
        yield url


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
