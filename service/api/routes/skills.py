"""GET /skills and GET /skills/{name}: versions and readiness."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException

from service.deps import StateDep
from service.schemas import ErrorResponse, SkillSummary

router = APIRouter(tags=["skills"])


@router.get("/skills", response_model=list[SkillSummary])
def list_skills(state: StateDep) -> list[SkillSummary]:
    """Every skill model the service can use, with its versions and whether each is ready."""
    return state.catalog.list_skills()


@router.get("/skills/{name}", response_model=SkillSummary, responses={404: {"model": ErrorResponse}})
def get_skill(name: str, state: StateDep) -> SkillSummary:
    try:
        return state.catalog.describe(name)
    except (KeyError, ValueError):  # unknown, or not even a valid name
        raise HTTPException(404, f"no skill named {name!r}; GET /skills lists them") from None
