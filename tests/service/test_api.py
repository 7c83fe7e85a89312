"""The planning API over real HTTP: plan, errors with locations, limits, skills, health, metrics."""

from __future__ import annotations

import threading
import time
from typing import Any

import httpx
import pytest

from gfc.examples import load_example
from gfc.planner.library import InMemoryLibrary
from service.settings import Settings
from tests.service.conftest import running_server


def small(plan: dict[str, Any], **options: Any) -> dict[str, Any]:
    plan["options"] = {"candidates": 4, "top_k": 2, "steps": 5, "seed": 0, **options}
    return plan


def test_plan_returns_ranked_candidates_for_every_step(client: httpx.Client) -> None:
    response = client.post(
        "/plan", json=small(load_example("hammer_place")), headers={"X-Request-ID": "abc-1"}
    )
    assert response.status_code == 200, response.text
    assert response.headers["x-request-id"] == "abc-1"
    body = response.json()
    assert body["request_id"] == "abc-1"
    assert len(body["candidates"]) == 2
    first = body["candidates"][0]
    assert [s["skill"] for s in first["steps"]] == ["pick", "move", "regrasp", "place"]
    assert all(len(s["action"]) == 9 and len(s["action_pose"]) == 7 for s in first["steps"])
    goal = [r for r in first["residuals"] if r["source"] == "goal"]
    assert [r["type"] for r in goal] == ["inside"]
    implied = {r["type"] for r in first["residuals"] if r["source"] == "implied"}
    assert implied == {"reach", "grasps_apart", "placed_reach"}
    assert body["candidates"][0]["cost"] <= body["candidates"][1]["cost"]
    assert set(body["models"]) == {"pick.hammer", "move.hammer", "regrasp.hammer", "place.hammer.box"}
    assert body["timing"]["total_s"] > 0


def test_same_seed_same_answer(client: httpx.Client) -> None:
    a = client.post("/plan", json=small(load_example("hammer_place"), seed=7)).json()
    b = client.post("/plan", json=small(load_example("hammer_place"), seed=7)).json()
    assert a["candidates"] == b["candidates"]


def test_symbolic_error_names_step_and_field(client: httpx.Client) -> None:
    plan = small(load_example("hammer_place"))
    plan["skeleton"][1]["robot"] = "right"
    response = client.post("/plan", json=plan)
    assert response.status_code == 422
    body = response.json()
    assert body["error"] == "invalid plan"
    assert {"loc": "skeleton[1].object", "message": body["detail"][0]["message"]} in body["detail"]
    assert "does not hold 'hammer'" in body["detail"][0]["message"]


def test_schema_error_is_located_like_a_json_path(client: httpx.Client) -> None:
    plan = small(load_example("hammer_place"))
    plan["scene"]["objects"][0]["pose"] = [0.45, 0.25, 0.64, 0, 0, 0, 2]
    response = client.post("/plan", json=plan)
    assert response.status_code == 422
    locs = [d["loc"] for d in response.json()["detail"]]
    assert "scene.objects[0].pose" in locs


def test_unknown_skill_model_is_404(client: httpx.Client) -> None:
    plan = small(load_example("hammer_place"))
    plan["skeleton"][0]["model"] = "pick.anvil"
    response = client.post("/plan", json=plan)
    assert response.status_code == 404
    assert "pick.anvil" in response.json()["detail"][0]["message"]


def test_oversized_body_is_413(client: httpx.Client) -> None:
    plan = small(load_example("hammer_place"))
    plan["padding"] = "x" * 300_000
    response = client.post("/plan", json=plan)
    assert response.status_code == 413
    assert response.json()["error"] == "request body too large"


def test_skills_and_readiness(client: httpx.Client) -> None:
    skills = client.get("/skills").json()
    names = {s["name"] for s in skills}
    assert {"pick.hammer", "move.nail"} <= names and "strike.hammer.nail" not in names  # terminal: no model
    assert all(v["ready"] for s in skills for v in s["versions"])
    assert client.get("/skills/pick.hammer").json()["name"] == "pick.hammer"
    missing = client.get("/skills/pick.anvil")
    assert missing.status_code == 404 and "GET /skills" in missing.json()["error"]
    assert client.get("/health/live").json() == {"status": "live"}
    assert client.get("/health/ready").status_code == 200


def test_metrics_and_openapi(client: httpx.Client) -> None:
    client.get("/health/live")
    text = client.get("/metrics").text
    assert "gfc_http_requests_total" in text and "gfc_plan_seconds" in text
    spec = client.get("/openapi.json").json()
    assert "/plan" in spec["paths"] and "PlanRequest" in str(spec["components"])


def test_empty_library_is_not_ready() -> None:
    with running_server(Settings(), InMemoryLibrary({})) as url:
        response = httpx.get(f"{url}/health/ready", timeout=30)
    assert response.status_code == 503
    assert "empty" in response.json()["reason"]


def test_overload_answers_503_with_retry_after(library: InMemoryLibrary) -> None:
    settings = Settings(max_concurrent_plans=1, max_queued_plans=0, max_batch=1, retry_after_s=2)
    slow = small(load_example("hammer_nail"), steps=200, candidates=16, top_k=1)
    results: list[int] = []
    with running_server(settings, library) as url:
        first = threading.Thread(
            target=lambda: results.append(httpx.post(f"{url}/plan", json=slow, timeout=120).status_code)
        )
        first.start()
        time.sleep(0.5)  # the first plan is sampling now
        second = httpx.post(f"{url}/plan", json=small(load_example("hammer_place")), timeout=60)
        first.join()
    assert second.status_code == 503
    assert second.headers["retry-after"] == "2"
    assert second.json()["error"] == "overloaded"
    assert results == [200]


def test_management_endpoints_are_off_without_a_token(client: httpx.Client) -> None:
    response = client.post("/admin/skills/pick.hammer/unload")
    assert response.status_code == 404
    assert "GFC_MANAGEMENT_TOKEN" in response.json()["error"]


def test_concurrent_plans_share_a_batch_and_keep_their_answers(library: InMemoryLibrary) -> None:
    settings = Settings(batch_window_ms=300, max_batch=8)
    plans = [small(load_example("hammer_place"), seed=s) for s in range(4)]
    with running_server(settings, library) as url:
        alone = httpx.post(f"{url}/plan", json=plans[0], timeout=60).json()
        results: dict[int, dict[str, Any]] = {}

        def send(i: int) -> None:
            results[i] = httpx.post(f"{url}/plan", json=plans[i], timeout=60).json()

        threads = [threading.Thread(target=send, args=(i,)) for i in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        metrics = httpx.get(f"{url}/metrics", timeout=30).text
    assert max(r["timing"]["batched_with"] for r in results.values()) >= 1  # some shared a run
    assert "gfc_plan_batch_size_count" in metrics
    for a, b in zip(alone["candidates"], results[0]["candidates"], strict=True):
        for sa, sb in zip(a["steps"], b["steps"], strict=True):
            assert sa["action"] == pytest.approx(sb["action"], abs=1e-4)
