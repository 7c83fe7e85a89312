"""FastAPI dependencies as ``Annotated`` aliases (full-stack-fastapi-template style)."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from service.state import ServiceState


def get_state(request: Request) -> ServiceState:
    state: ServiceState = request.app.state.gfc
    return state


def get_request_id(request: Request) -> str:
    return str(request.scope.get("state", {}).get("request_id", ""))


StateDep = Annotated[ServiceState, Depends(get_state)]
RequestIdDep = Annotated[str, Depends(get_request_id)]
