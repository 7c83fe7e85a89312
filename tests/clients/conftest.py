"""A real service (uvicorn on loopback) for the SDK, and a scripted one for errors and retries."""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse, Response

from gfc.examples import load_example
from gfc.plan import compile_plan
from gfc.planner.library import InMemoryLibrary, random_library
from service.jobs import JobStore, open_job_store
from service.local_server import free_port, serve_in_thread
from service.settings import Settings
from tests.service.conftest import running_server


def small(plan: dict[str, Any], **options: Any) -> dict[str, Any]:
    plan["options"] = {"candidates": 4, "top_k": 2, "steps": 4, "seed": 0, **options}
    return plan


@pytest.fixture(scope="module")
def library() -> InMemoryLibrary:
    """Randomly initialised models for hammer_place's skills: enough to exercise HTTP."""
    return random_library(compile_plan(load_example("hammer_place")))


@dataclass
class Service:
    url: str
    settings: Settings
    jobs: JobStore  # the service's job store, opened again: tests play the worker

    def finish(self, job_id: str, result: dict[str, Any]) -> None:
        claimed = self.jobs.claim("test-worker", lease_s=30)
        assert claimed is not None and claimed.id == job_id, claimed
        assert self.jobs.complete(job_id, "test-worker", result)


@pytest.fixture
def service(library: InMemoryLibrary, tmp_path: Path) -> Iterator[Service]:
    """A fresh service per test, so that each test's jobs are its own."""
    settings = Settings(data_dir=tmp_path / "var", max_body_bytes=200_000)
    with running_server(settings, library) as url:
        yield Service(url, settings, open_job_store(settings.job_store_url()))


# ---- scripted server -------------------------------------------------------------------------


@dataclass
class Reply:
    status: int
    body: Any = None
    headers: dict[str, str] = field(default_factory=dict)
    delay_s: float = 0.0


@dataclass
class Seen:
    method: str
    path: str
    headers: dict[str, str]
    body: bytes
    at: float


@dataclass
class Script:
    """Answers every request with the next queued reply (and records it)."""

    url: str
    replies: list[Reply] = field(default_factory=list)
    seen: list[Seen] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def then(self, *replies: Reply) -> Script:
        with self.lock:
            self.replies.extend(replies)
        return self


def scripted_app(script: Script) -> FastAPI:
    app = FastAPI()

    @app.api_route("/{path:path}", methods=["GET", "POST", "PUT"])
    async def answer(path: str, request: Request) -> Response:
        body = await request.body()
        with script.lock:
            script.seen.append(
                Seen(request.method, "/" + path, dict(request.headers), body, time.monotonic())
            )
            reply = script.replies.pop(0) if script.replies else Reply(599, {"error": "script is empty"})
        if reply.delay_s:
            await asyncio.sleep(reply.delay_s)
        if isinstance(reply.body, bytes):
            return Response(reply.body, status_code=reply.status, headers=reply.headers)
        return JSONResponse(reply.body, status_code=reply.status, headers=reply.headers)

    return app


@pytest.fixture
def script() -> Iterator[Script]:
    port = free_port()
    script = Script(f"http://127.0.0.1:{port}")
    with serve_in_thread(scripted_app(script), port):
        yield script


VERIFIED = {
    "candidates": [
        {
            "rank": 0,
            "success": True,
            "goal_satisfied": True,
            "goal_report": ["inside(hammer, box): ok"],
            "steps": [
                {
                    "step": 0,
                    "skill": "pick",
                    "robot": "left",
                    "success": True,
                    "failure_type": None,
                    "reason": "",
                },
                {
                    "step": 1,
                    "skill": "move",
                    "robot": "left",
                    "success": False,
                    "failure_type": 2,
                    "reason": "no path",
                },
            ],
            "wall_s": 1.5,
            "frames": ["rank0.png"],
        }
    ],
    "any_success": True,
    "first_successful_rank": 0,
}
"""A verification result as a worker reports it."""


def png_bytes() -> bytes:
    return b"\x89PNG\r\n\x1a\n" + b"\x00" * 16


def write_frame(settings: Settings, job_id: str, name: str) -> Path:
    path = settings.data_dir / "renders" / job_id / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(png_bytes())
    return path
