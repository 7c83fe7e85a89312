"""The load benchmark's machinery on a tiny budget: overload shows up as 503 + Retry-After only."""

from __future__ import annotations

from pathlib import Path

import pytest

from service.load_bench import load_markdown, run_load
from service.settings import Settings


@pytest.mark.slow
def test_overloaded_service_answers_only_200_or_503_with_retry_after(tmp_path: Path) -> None:
    settings = Settings(
        data_dir=tmp_path, max_concurrent_plans=1, max_queued_plans=0, max_batch=1, retry_after_s=1
    )
    result = run_load(clients=6, requests=18, duration_s=60, candidates=4, steps=20, settings=settings)
    assert result["requests_sent"] == 18
    assert set(result["statuses"]) <= {"200", "503"}
    assert result["statuses"].get("503", 0) > 0  # six clients, room for one: some are turned away
    assert result["statuses"].get("200", 0) > 0
    assert result["unexpected_5xx"] == 0 and result["503_without_retry_after"] == 0
    assert result["latency_p50_s"] <= result["latency_p99_s"]
    assert "| 6 | 18 |" in load_markdown(result, "test")
