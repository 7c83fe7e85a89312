"""Load benchmark: many concurrent clients on loopback against a real uvicorn, bounded in count
and time. Reports throughput, latency percentiles and every status code seen."""

from __future__ import annotations

import asyncio
import statistics
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx

from gfc.examples import load_example
from gfc.plan import compile_plan
from gfc.planner.library import random_library
from service.catalog import InMemoryCatalog
from service.local_server import serve_in_thread
from service.main import create_app
from service.settings import Settings


@contextmanager
def _server(settings: Settings, port: int) -> Iterator[str]:
    library = random_library(compile_plan(load_example("hammer_place")))
    with serve_in_thread(create_app(settings, library, InMemoryCatalog(library)), port) as url:
        yield url


def _percentile(values: list[float], q: float) -> float:
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


async def _drive(
    url: str, clients: int, requests: int, duration_s: float, plan: dict[str, Any]
) -> dict[str, Any]:
    statuses: Counter[str] = Counter()
    latencies: list[float] = []
    missing_retry_after = 0
    sent = 0
    deadline = time.monotonic() + duration_s

    async def client(http: httpx.AsyncClient) -> None:
        nonlocal sent, missing_retry_after
        while sent < requests and time.monotonic() < deadline:
            sent += 1
            start = time.perf_counter()
            try:
                response = await http.post("/plan", json=plan)
            except httpx.HTTPError as exc:
                statuses[type(exc).__name__] += 1
                continue
            latencies.append(time.perf_counter() - start)
            statuses[str(response.status_code)] += 1
            if response.status_code == 503:
                if "retry-after" not in response.headers:
                    missing_retry_after += 1
                await asyncio.sleep(float(response.headers.get("retry-after", "1")))

    began = time.perf_counter()
    async with httpx.AsyncClient(base_url=url, timeout=120) as http:
        await asyncio.gather(*(client(http) for _ in range(clients)))
    wall = time.perf_counter() - began
    ok = statuses.get("200", 0)
    return {
        "clients": clients,
        "requests_sent": sent,
        "wall_s": wall,
        "throughput_ok_per_s": ok / wall if wall > 0 else 0.0,
        "latency_p50_s": _percentile(latencies, 0.50),
        "latency_p99_s": _percentile(latencies, 0.99),
        "latency_mean_s": statistics.fmean(latencies) if latencies else float("nan"),
        "statuses": dict(sorted(statuses.items())),
        "unexpected_5xx": sum(n for s, n in statuses.items() if s.startswith("5") and s != "503"),
        "503_without_retry_after": missing_retry_after,
    }


def run_load(
    clients: int = 8,
    requests: int = 200,
    duration_s: float = 60.0,
    candidates: int = 10,
    steps: int = 50,
    port: int = 0,
    settings: Settings | None = None,
) -> dict[str, Any]:
    plan = load_example("hammer_place")
    plan["options"] = {"candidates": candidates, "top_k": min(5, candidates), "steps": steps, "seed": 0}
    settings = settings or Settings(data_dir=Path("var/bench"))
    with _server(settings, port) as url:
        result = asyncio.run(_drive(url, clients, requests, duration_s, plan))
    result.update(
        {
            "workload": "hammer_place (4 steps), random DiT skill models",
            "candidates": candidates,
            "steps": steps,
            "max_concurrent_plans": settings.max_concurrent_plans,
            "max_queued_plans": settings.max_queued_plans,
            "max_batch": settings.max_batch,
            "batch_window_ms": settings.batch_window_ms,
        }
    )
    return result


def load_markdown(result: dict[str, Any], command: str) -> str:
    statuses = ", ".join(f"{s}: {n}" for s, n in result["statuses"].items())
    return "\n".join(
        [
            "# Load test of POST /plan",
            "",
            f"Workload: {result['workload']}, {result['candidates']} candidates, {result['steps']} steps; "
            f"{result['clients']} concurrent clients on loopback, at most {result['requests_sent']} requests; "
            f"the service runs {result['max_concurrent_plans']} sampling runs at once, each batching up to "
            f"{result['max_batch']} plans that arrive within {result['batch_window_ms']:g} ms, holds "
            f"{result['max_queued_plans']} more waiting, and refuses the rest with 503 + Retry-After.",
            "",
            "| clients | requests | wall s | ok/s | p50 s | p99 s | statuses | 5xx other than 503 | 503 without Retry-After |",
            "| ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: | ---: |",
            f"| {result['clients']} | {result['requests_sent']} | {result['wall_s']:.1f} | "
            f"{result['throughput_ok_per_s']:.2f} | {result['latency_p50_s']:.3f} | {result['latency_p99_s']:.3f} | "
            f"{statuses} | {result['unexpected_5xx']} | {result['503_without_retry_after']} |",
            "",
            f"Command: `{command}`",
            "",
        ]
    )
