"""Build the FastAPI app: state, middleware, routes, error handlers."""

from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from gfc import __version__
from gfc.plan.compiler import issues_from_errors
from gfc.planner.library import SkillLibrary
from service.admin import SkillAdmin
from service.api.routes import admin as admin_routes
from service.api.routes import health, metrics, plan, skills, verify
from service.batcher import PlanBatcher
from service.catalog import SkillCatalog
from service.jobs import JobStore, open_job_store
from service.limits import Admission
from service.metrics import Metrics
from service.middleware import RequestContext
from service.settings import Settings
from service.state import ServiceState


def _request_id(request: Request) -> str:
    return str(request.scope.get("state", {}).get("request_id", ""))


def create_app(
    settings: Settings,
    library: SkillLibrary,
    catalog: SkillCatalog,
    jobs: JobStore | None = None,
    admin: SkillAdmin | None = None,
) -> FastAPI:
    """The service around a skill library. ``gfc serve`` passes the skill store's library; the
    job store defaults to ``settings.job_store_url()`` (a SQLite file under the data dir)."""
    app = FastAPI(
        title="gfc planning service",
        version=__version__,
        description=(
            "Send a symbolic plan (scene, skeleton, constraints, goal); get continuous skill "
            "parameters for every step, ranked, from composed per-skill diffusion models."
        ),
    )
    metrics_ = Metrics.create()
    app.state.gfc = ServiceState(
        settings=settings,
        library=library,
        catalog=catalog,
        admission=Admission(settings.max_concurrent_plans * settings.max_batch + settings.max_queued_plans),
        metrics=metrics_,
        batcher=PlanBatcher(
            library,
            window_s=settings.batch_window_ms / 1000,
            max_batch=settings.max_batch,
            workers=settings.max_concurrent_plans,
            torch_threads=settings.torch_threads,
            on_batch=metrics_.batch_size.observe,
        ),
        jobs=jobs or open_job_store(settings.job_store_url()),
        admin=admin,
    )
    for router in (
        plan.router,
        verify.router,
        skills.router,
        health.router,
        metrics.router,
        admin_routes.router,
    ):
        app.include_router(router)

    @app.exception_handler(RequestValidationError)
    async def invalid_request(request: Request, exc: RequestValidationError) -> JSONResponse:
        issues = issues_from_errors(exc.errors(), drop_prefix=("body",))
        return JSONResponse(
            status_code=422,
            content={
                "error": "invalid plan" if request.url.path == "/plan" else "invalid request",
                "detail": [{"loc": i.loc, "message": i.message} for i in issues],
                "request_id": _request_id(request),
            },
        )

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        return JSONResponse(
            status_code=exc.status_code,
            content={"error": str(exc.detail), "detail": [], "request_id": _request_id(request)},
            headers=exc.headers,
        )

    @app.middleware("http")
    async def count(request: Request, call_next):  # type: ignore[no-untyped-def]
        response = await call_next(request)
        route = request.scope.get("route")
        path = getattr(route, "path", "unmatched")
        app.state.gfc.metrics.requests.labels(route=path, status=str(response.status_code)).inc()
        return response

    if settings.log_json:
        logging.getLogger("gfc.service").setLevel(logging.INFO)
    app.add_middleware(RequestContext, max_body_bytes=settings.max_body_bytes)
    return app
