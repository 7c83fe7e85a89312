"""Every call of the synchronous client against the real service over HTTP."""

from __future__ import annotations

from pathlib import Path

import pytest
from gfc_client import (
    Client,
    ConflictError,
    JobStatus,
    JobWaitTimeout,
    NotFoundError,
    PlanResponse,
    RequestTooLargeError,
    UnprocessableEntityError,
)

from gfc.examples import load_example
from tests.clients.conftest import VERIFIED, Service, png_bytes, small, write_frame


def test_plan_returns_typed_ranked_candidates(service: Service) -> None:
    with Client(service.url) as client:
        response = client.plan(small(load_example("hammer_place")), request_id="sdk-1")
    assert isinstance(response, PlanResponse)
    assert response.request_id == "sdk-1"
    assert [c.rank for c in response.candidates] == [0, 1]
    assert response.best.cost <= response.candidates[1].cost
    assert [s.skill for s in response.best.steps] == ["pick", "move", "regrasp", "place"]
    assert all(len(s.action) == 9 for s in response.best.steps)
    assert [r.type for r in response.best.residuals if r.source == "goal"] == ["inside"]
    assert isinstance(response.best.satisfied, bool)
    assert set(response.models) == {"pick.hammer", "move.hammer", "regrasp.hammer", "place.hammer.box"}


def test_invalid_plan_raises_with_locations(service: Service) -> None:
    plan = small(load_example("hammer_place"))
    plan["skeleton"][1]["robot"] = "right"
    with Client(service.url) as client, pytest.raises(UnprocessableEntityError) as caught:
        client.plan(plan)
    error = caught.value
    assert error.status_code == 422
    assert error.error == "invalid plan"
    assert "skeleton[1].object" in [issue.loc for issue in error.detail]
    assert "skeleton[1].object" in str(error)  # the message names the place to fix
    assert error.request_id


def test_unknown_skill_model_is_not_found(service: Service) -> None:
    plan = small(load_example("hammer_place"))
    plan["skeleton"][0]["model"] = "pick.anvil"
    with Client(service.url) as client, pytest.raises(NotFoundError) as caught:
        client.plan(plan)
    assert "pick.anvil" in caught.value.detail[0].message


def test_oversized_plan_is_too_large(service: Service) -> None:
    plan = small(load_example("hammer_place"))
    plan["padding"] = "x" * 300_000
    with Client(service.url, max_retries=0) as client, pytest.raises(RequestTooLargeError) as caught:
        client.plan(plan)
    assert caught.value.status_code == 413


def test_verify_by_plan_id_then_wait_and_fetch_frames(service: Service) -> None:
    with Client(service.url) as client:
        planned = client.plan(small(load_example("hammer_place")))
        accepted = client.verify(plan_id=planned.plan_id, top_k=1, idempotency_key="k-1")
        assert accepted.status is JobStatus.QUEUED
        assert accepted.url == f"/jobs/{accepted.job_id}"
        again = client.verify(plan_id=planned.plan_id, top_k=1, idempotency_key="k-1")
        assert again.job_id == accepted.job_id  # same key: the same job, not a second one
        with pytest.raises(ConflictError):  # same key, different request
            client.verify(plan_id=planned.plan_id, top_k=2, idempotency_key="k-1")

        queued = client.get_job(accepted.job_id)
        assert queued.status is JobStatus.QUEUED and not queued.done and queued.verification is None
        with pytest.raises(JobWaitTimeout) as waited:
            client.wait_for_job(accepted.job_id, timeout=0.3, poll_interval=0.1)
        assert waited.value.job.status is JobStatus.QUEUED

        service.finish(accepted.job_id, VERIFIED)
        write_frame(service.settings, accepted.job_id, "rank0.png")
        job = client.wait_for_job(accepted.job_id, timeout=10, poll_interval=0.1)
        assert job.status is JobStatus.SUCCEEDED and job.done
        verified = job.verification
        assert verified is not None and verified.any_success
        assert verified.candidates[0].steps[1].failure_type == 2
        frame = client.get_frame(accepted.job_id, verified.candidates[0].frames[0])
        assert frame == png_bytes()
        with pytest.raises(NotFoundError):
            client.get_frame(accepted.job_id, "rank9.png")
        with pytest.raises(NotFoundError):
            client.get_job("nope")


def test_verify_with_plan_and_candidates_gets_a_fresh_key_per_call(service: Service) -> None:
    plan = small(load_example("hammer_place"))
    with Client(service.url) as client:
        candidates = client.plan(plan).candidates
        first = client.verify(plan=plan, candidates=candidates)
        second = client.verify(plan=plan, candidates=[c.model_dump() for c in candidates])
    assert first.job_id != second.job_id  # no key given: each call is its own submission


def test_verify_of_unknown_plan_id_is_not_found(service: Service) -> None:
    with Client(service.url) as client, pytest.raises(NotFoundError) as caught:
        client.verify(plan_id="0" * 32)
    assert "POST /plan returns plan_id" in caught.value.message


def test_verify_arguments_are_checked_before_sending() -> None:
    with Client("http://127.0.0.1:9") as client:
        with pytest.raises(ValueError, match="plan_id"):
            client.verify()
        with pytest.raises(ValueError, match="not both"):
            client.verify(plan_id="a", plan={"scene": {}}, candidates=[])


def test_skills_health_and_metrics(service: Service) -> None:
    with Client(service.url) as client:
        skills = client.list_skills()
        assert {s.name for s in skills} == {
            "pick.hammer",
            "move.hammer",
            "regrasp.hammer",
            "place.hammer.box",
        }
        pick = client.get_skill("pick.hammer")
        assert pick.name == "pick.hammer" and pick.versions[0].ready
        with pytest.raises(NotFoundError):
            client.get_skill("pick.anvil")
        assert client.live().status == "live"
        readiness = client.ready()
        assert readiness.ready and readiness.skills == 4
        assert "gfc" in client.metrics()


def test_not_ready_is_an_answer_not_an_error(tmp_path: Path) -> None:
    from gfc.planner.library import InMemoryLibrary
    from service.settings import Settings
    from tests.service.conftest import running_server

    with (
        running_server(Settings(data_dir=tmp_path / "var"), InMemoryLibrary({})) as url,
        Client(url, max_retries=0) as client,
    ):
        readiness = client.ready()
    assert not readiness.ready
    assert readiness.reason is not None and "empty" in readiness.reason
