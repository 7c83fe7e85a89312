"""The asyncio client: the same calls, errors and retries as the synchronous one."""

from __future__ import annotations

import asyncio

import pytest
from gfc_client import (
    APITimeoutError,
    AsyncClient,
    JobStatus,
    JobWaitTimeout,
    NotFoundError,
    RateLimitError,
    UnprocessableEntityError,
)

from gfc.examples import load_example
from tests.clients.conftest import VERIFIED, Reply, Script, Service, png_bytes, small, write_frame
from tests.clients.test_errors_and_retries import OVERLOADED, plan_response


def test_every_call(service: Service) -> None:
    async def scenario() -> None:
        async with AsyncClient(service.url) as client:
            plans = await asyncio.gather(
                *(client.plan(small(load_example("hammer_place"), seed=s)) for s in range(3))
            )
            assert len({p.plan_id for p in plans}) == 3
            assert plans[0].best.steps[0].skill == "pick"

            accepted = await client.verify(plan_id=plans[0].plan_id, top_k=1)
            assert (await client.get_job(accepted.job_id)).status is JobStatus.QUEUED
            with pytest.raises(JobWaitTimeout):
                await client.wait_for_job(accepted.job_id, timeout=0.2, poll_interval=0.05)
            service.finish(accepted.job_id, VERIFIED)
            write_frame(service.settings, accepted.job_id, "rank0.png")
            job = await client.wait_for_job(accepted.job_id, timeout=10, poll_interval=0.05)
            assert job.verification is not None and job.verification.first_successful_rank == 0
            assert await client.get_frame(accepted.job_id, "rank0.png") == png_bytes()

            skills = await client.list_skills()
            assert len(skills) == 4
            assert (await client.get_skill("move.hammer")).name == "move.hammer"
            with pytest.raises(NotFoundError):
                await client.get_skill("nope")
            assert (await client.live()).status == "live"
            assert (await client.ready()).ready
            assert "gfc" in await client.metrics()

            bad = small(load_example("hammer_place"))
            bad["scene"]["objects"][0]["pose"] = [0.45, 0.25, 0.64, 0, 0, 0, 2]
            with pytest.raises(UnprocessableEntityError) as caught:
                await client.plan(bad)
            assert "scene.objects[0].pose" in [i.loc for i in caught.value.detail]

    asyncio.run(scenario())


def test_retry_after_then_success_and_timeouts(script: Script) -> None:
    script.then(
        Reply(503, OVERLOADED, {"Retry-After": "1"}),
        Reply(200, plan_response()),
        Reply(503, OVERLOADED, {"Retry-After": "0"}),
        Reply(200, [], delay_s=0.6),
    )

    async def scenario() -> None:
        async with AsyncClient(script.url, max_retries=1) as client:
            response = await client.plan(load_example("hammer_place"))
            assert response.plan_id == "p"
        async with AsyncClient(script.url, max_retries=0) as client:
            with pytest.raises(RateLimitError):
                await client.list_skills()
            with pytest.raises(APITimeoutError):
                await client.list_skills(timeout=0.1)

    asyncio.run(scenario())
    assert script.seen[1].at - script.seen[0].at >= 0.95
