"""POST /verify (a job), GET /jobs/{id}, GET /jobs/{id}/frames/{name}."""

from __future__ import annotations

import asyncio
from typing import Annotated, Any

from fastapi import APIRouter, Header, HTTPException
from fastapi.responses import FileResponse, JSONResponse

from gfc.plan import PlanError, compile_plan, parse_plan
from service.deps import RequestIdDep, StateDep
from service.jobs import IdempotencyConflict
from service.schemas import ErrorResponse, JobAccepted, JobView, VerifyRequest
from service.verification import VERIFY_KIND

router = APIRouter(tags=["verification"])


def _payload(body: VerifyRequest, stored: dict[str, Any] | None, limit: int) -> dict[str, Any]:
    if body.plan_id is not None:
        if stored is None:
            raise HTTPException(404, f"no plan with id {body.plan_id!r}; POST /plan returns plan_id")
        plan, candidates = stored["plan"], stored["candidates"]
    elif body.plan is not None and body.candidates is not None:
        plan, candidates = body.plan, body.candidates
    else:
        raise HTTPException(422, "send either plan_id, or plan with candidates")
    try:
        compile_plan(parse_plan(plan))
    except PlanError as exc:
        raise HTTPException(422, "invalid plan: " + "; ".join(str(i) for i in exc.issues)) from None
    chosen = sorted(candidates, key=lambda c: int(c.get("rank", 0)))[: body.top_k]
    if not chosen:
        raise HTTPException(422, "no candidates to verify")
    if len(chosen) > limit:
        raise HTTPException(422, f"{len(chosen)} candidates; one job verifies at most {limit} (use top_k)")
    steps = [{"rank": c.get("rank", i), "steps": c.get("steps", [])} for i, c in enumerate(chosen)]
    return {"plan": plan, "candidates": steps, "seed": body.seed}


@router.post(
    "/verify",
    status_code=202,
    response_model=JobAccepted,
    responses={404: {"model": ErrorResponse}, 409: {"model": ErrorResponse}, 422: {"model": ErrorResponse}},
)
async def verify(
    body: VerifyRequest,
    state: StateDep,
    request_id: RequestIdDep,
    idempotency_key: Annotated[str | None, Header(max_length=128)] = None,
) -> JobAccepted | JSONResponse:
    """Queue a verification job: a worker executes the candidates in the simulator. Send an
    ``Idempotency-Key`` header to make retries safe: the same key returns the same job."""
    stored = await asyncio.to_thread(state.jobs.get_plan, body.plan_id) if body.plan_id else None
    payload = _payload(body, stored, state.settings.max_verify_candidates)
    try:
        job = await asyncio.to_thread(
            state.jobs.submit, VERIFY_KIND, payload, idempotency_key, body.max_attempts
        )
    except IdempotencyConflict as exc:
        return JSONResponse(
            status_code=409, content={"error": str(exc), "detail": [], "request_id": request_id}
        )
    return JobAccepted(job_id=job.id, status=job.status.value, url=f"/jobs/{job.id}")


@router.get("/jobs/{job_id}", response_model=JobView, responses={404: {"model": ErrorResponse}})
async def get_job(job_id: str, state: StateDep) -> JobView:
    job = await asyncio.to_thread(state.jobs.get, job_id)
    if job is None:
        raise HTTPException(404, f"no job {job_id!r}")
    return JobView.model_validate(job.public())


@router.get("/jobs/{job_id}/frames/{name}", responses={404: {"model": ErrorResponse}})
async def get_frame(job_id: str, name: str, state: StateDep) -> FileResponse:
    """A rendered key-frame strip of one verified candidate (``rank0.png``, ...)."""
    if not job_id.isalnum() or not name.endswith(".png") or "/" in name or name.startswith("."):
        raise HTTPException(404, "no such frame")
    path = state.settings.data_dir / "renders" / job_id / name
    if not path.is_file():
        raise HTTPException(404, f"no frame {name!r} for job {job_id!r}")
    return FileResponse(path, media_type="image/png")
