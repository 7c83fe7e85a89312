"""Management endpoints: off unless GFC_MANAGEMENT_TOKEN is set; then a bearer token is needed."""

from __future__ import annotations

import secrets
from typing import Annotated, Any

from fastapi import APIRouter, Depends, Header, HTTPException
from pydantic import BaseModel, Field

from service.admin import SkillAdmin
from service.deps import StateDep
from skill_store import IntegrityError

router = APIRouter(prefix="/admin", tags=["management"])


def require_admin(state: StateDep, authorization: Annotated[str | None, Header()] = None) -> SkillAdmin:
    token = state.settings.management_token
    if token is None or state.admin is None:
        raise HTTPException(404, "management endpoints are off (set GFC_MANAGEMENT_TOKEN to turn them on)")
    given = (authorization or "").removeprefix("Bearer ").strip()
    if not given or not secrets.compare_digest(given.encode(), token.encode()):
        raise HTTPException(401, "management endpoints need 'Authorization: Bearer <GFC_MANAGEMENT_TOKEN>'")
    return state.admin


AdminDep = Annotated[SkillAdmin, Depends(require_admin)]


class AliasMove(BaseModel):
    version: int = Field(ge=1)
    reason: str | None = Field(None, max_length=500)


@router.post("/skills/{name}/load")
def load(name: str, admin: AdminDep, version: int | None = None) -> dict[str, Any]:
    try:
        return {"loaded": admin.load(name, version)}
    except KeyError as exc:
        raise HTTPException(404, str(exc)) from None
    except IntegrityError as exc:
        raise HTTPException(409, f"refused: {exc}") from None


@router.post("/skills/{name}/unload")
def unload(name: str, admin: AdminDep, version: int | None = None) -> dict[str, Any]:
    return {"unloaded": admin.unload(name, version)}


@router.put("/skills/{name}/aliases/{alias}")
def move_alias(name: str, alias: str, move: AliasMove, admin: AdminDep) -> dict[str, Any]:
    try:
        return admin.alias(name, alias, move.version, move.reason)
    except KeyError as exc:
        raise HTTPException(404, str(exc)) from None
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from None
