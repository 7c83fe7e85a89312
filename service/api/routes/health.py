"""Liveness (the process answers) and readiness (skills load and run)."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from service.deps import StateDep

router = APIRouter(tags=["health"])


@router.get("/health/live")
def live() -> dict[str, str]:
    return {"status": "live"}


@router.get("/health/ready")
def ready(state: StateDep) -> JSONResponse:
    """Ready when at least one skill exists and every skill's current version loads and runs."""
    skills = state.catalog.list_skills()
    broken = [f"{v.name}@{v.version}: {v.detail}" for s in skills for v in s.versions if not v.ready]
    if not skills:
        return JSONResponse(
            status_code=503,
            content={
                "status": "not ready",
                "reason": "the skill library is empty (train skills, then push them)",
            },
        )
    if broken:
        return JSONResponse(status_code=503, content={"status": "not ready", "reason": "; ".join(broken)})
    return JSONResponse(content={"status": "ready", "skills": len(skills)})
