"""POST /plan: compile a plan, sample candidates, return them ranked."""

from __future__ import annotations

import asyncio
import time
import uuid

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from gfc.plan import PlanError, PlanRequest, compile_plan
from service.deps import RequestIdDep, StateDep
from service.limits import Overloaded
from service.schemas import ErrorResponse, PlanResponse
from skill_store import IntegrityError

router = APIRouter(tags=["planning"])


def _error(
    status: int, error: str, request_id: str, detail: list[dict[str, str]] | None = None
) -> JSONResponse:
    body = ErrorResponse.model_validate({"error": error, "detail": detail or [], "request_id": request_id})
    return JSONResponse(status_code=status, content=body.model_dump())


@router.post(
    "/plan",
    response_model=PlanResponse,
    responses={
        404: {"model": ErrorResponse, "description": "a step names a skill model the library lacks"},
        413: {"model": ErrorResponse, "description": "request body too large"},
        422: {"model": ErrorResponse, "description": "invalid plan: every problem with its location"},
        503: {"model": ErrorResponse, "description": "overloaded: retry after Retry-After seconds"},
    },
)
async def plan(
    request: PlanRequest, state: StateDep, request_id: RequestIdDep
) -> PlanResponse | JSONResponse:
    """Sample continuous parameters for every step of a plan skeleton, ranked by how well they
    satisfy the constraints and the goal."""
    try:
        compiled = compile_plan(request)
    except PlanError as exc:
        return _error(422, "invalid plan", request_id, exc.to_json())
    try:
        async with state.admission:
            state.metrics.plans_in_flight.set(state.admission.in_flight)
            start = time.perf_counter()
            result = await state.batcher.plan(compiled, request.options)
            state.metrics.plan_seconds.observe(time.perf_counter() - start)
    except Overloaded as exc:
        state.metrics.rejected.inc()
        response = _error(503, "overloaded", request_id, [{"loc": "service", "message": str(exc)}])
        response.headers["Retry-After"] = str(state.settings.retry_after_s)
        return response
    except KeyError as exc:
        return _error(
            404, "unknown skill model", request_id, [{"loc": "skeleton", "message": str(exc.args[0])}]
        )
    except IntegrityError as exc:  # an explicitly pinned version that fails its checks
        return _error(
            503, "skill version unavailable", request_id, [{"loc": "skeleton", "message": str(exc)}]
        )
    except ValueError as exc:  # e.g. a model reference the store refuses ("../x")
        return _error(422, "invalid plan", request_id, [{"loc": "skeleton", "message": str(exc)}])
    finally:
        state.metrics.plans_in_flight.set(state.admission.in_flight)
    plan_id = uuid.uuid4().hex
    # Kept so that POST /verify can name this plan by its id.
    await asyncio.to_thread(
        state.jobs.save_plan, plan_id, {"plan": request.to_json_dict(), "candidates": result.candidates}
    )
    return PlanResponse.model_validate(
        {
            "request_id": request_id,
            "plan_id": plan_id,
            "candidates": result.candidates,
            "models": result.models,
            "timing": result.timing,
        }
    )
