"""Every endpoint as an ``Operation``: path, body, headers, and the typed parse of its answer."""

from __future__ import annotations

import uuid
from collections.abc import Mapping, Sequence
from typing import Any, Protocol, TypeVar
from urllib.parse import quote

import httpx
from pydantic import BaseModel, TypeAdapter

from gfc_client._flow import Operation
from gfc_client.models import (
    Candidate,
    Health,
    Job,
    JobAccepted,
    PlanResponse,
    Readiness,
    Skill,
)

M = TypeVar("M", bound=BaseModel)


class Buildable(Protocol):
    """Anything with ``build()`` returning the plan JSON (``PlanBuilder``)."""

    def build(self) -> dict[str, Any]: ...


PlanLike = Mapping[str, Any] | Buildable
CandidateLike = Candidate | Mapping[str, Any]


def _segment(value: str) -> str:
    if not value:
        raise ValueError("an id or name in a URL path must not be empty")
    return quote(value, safe="")


def _model(cls: type[M]) -> Any:
    def parse(response: httpx.Response) -> M:
        return cls.model_validate_json(response.content)

    return parse


def plan_json(plan: PlanLike) -> dict[str, Any]:
    return dict(plan) if isinstance(plan, Mapping) else plan.build()


def plan(plan: PlanLike, request_id: str | None) -> Operation[PlanResponse]:
    headers = {"X-Request-ID": request_id} if request_id else {}
    return Operation("POST", "/plan", _model(PlanResponse), json=plan_json(plan), headers=headers)


def verify(
    *,
    plan: PlanLike | None,
    candidates: Sequence[CandidateLike] | None,
    plan_id: str | None,
    top_k: int | None,
    seed: int,
    max_attempts: int,
    idempotency_key: str | None,
) -> Operation[JobAccepted]:
    """The key is made here, once per call, so every retry of this call carries the same one."""
    if plan_id is None and (plan is None or candidates is None):
        raise ValueError("verify needs plan_id=..., or plan=... with candidates=...")
    if plan_id is not None and (plan is not None or candidates is not None):
        raise ValueError("verify takes plan_id=... or plan=... with candidates=..., not both")
    body: dict[str, Any] = {"seed": seed, "max_attempts": max_attempts}
    if plan_id is not None:
        body["plan_id"] = plan_id
    else:
        assert plan is not None and candidates is not None
        body["plan"] = plan_json(plan)
        body["candidates"] = [
            c.model_dump(mode="json") if isinstance(c, Candidate) else dict(c) for c in candidates
        ]
    if top_k is not None:
        body["top_k"] = top_k
    key = idempotency_key or uuid.uuid4().hex
    return Operation(
        "POST",
        "/verify",
        _model(JobAccepted),
        json=body,
        headers={"Idempotency-Key": key},
        ok=frozenset({200, 202}),
    )


def get_job(job_id: str) -> Operation[Job]:
    return Operation("GET", f"/jobs/{_segment(job_id)}", _model(Job))


def get_frame(job_id: str, name: str) -> Operation[bytes]:
    return Operation("GET", f"/jobs/{_segment(job_id)}/frames/{_segment(name)}", lambda r: r.content)


_SKILLS: TypeAdapter[list[Skill]] = TypeAdapter(list[Skill])


def list_skills() -> Operation[list[Skill]]:
    return Operation("GET", "/skills", lambda r: _SKILLS.validate_json(r.content))


def get_skill(name: str) -> Operation[Skill]:
    return Operation("GET", f"/skills/{_segment(name)}", _model(Skill))


def live() -> Operation[Health]:
    return Operation("GET", "/health/live", _model(Health))


def _readiness(response: httpx.Response) -> Readiness:
    body = response.json()
    return Readiness.model_validate({**body, "ready": response.status_code == 200})


def ready() -> Operation[Readiness]:
    """503 means "not ready", an answer, not an error: it is returned, not raised or retried."""
    return Operation("GET", "/health/ready", _readiness, ok=frozenset({200, 503}))


def metrics() -> Operation[str]:
    return Operation("GET", "/metrics", lambda r: r.text)
