"""Response schemas of the HTTP API (separate from the library's internal structures)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field


class Issue(BaseModel):
    loc: str = Field(description="where: a JSON path such as skeleton[2].from")
    message: str = Field(description="what is wrong and what to do")


class ErrorResponse(BaseModel):
    error: str
    detail: list[Issue] = Field(default_factory=list)
    request_id: str | None = None


class StepParameters(BaseModel):
    step: int
    skill: str
    model: str | None = Field(
        None, description="skill model sampled (none for a terminal skill such as strike)"
    )
    action: list[float] = Field(description="raw action vector (rotation columns orthonormalised)")
    action_named: dict[str, float] | None = None
    action_pose: list[float] | None = Field(None, description="9-D pose actions as [x, y, z, qx, qy, qz, qw]")


class NodeState(BaseModel):
    pose: list[float] = Field(description="[x, y, z, qx, qy, qz, qw], world frame")
    gripper: float | None = Field(None, description="robots: gripper opening in metres")


class Residual(BaseModel):
    type: str
    source: str = Field(description="constraints or goal")
    index: int
    max_scaled_residual: float = Field(description="worst residual in tolerances (<= 1: satisfied)")
    satisfied: bool


class Candidate(BaseModel):
    rank: int
    cost: float = Field(description="spatial energy of constraints and goal; lower is better")
    steps: list[StepParameters]
    nodes: dict[str, NodeState] = Field(description="predicted state of every sampled node version")
    residuals: list[Residual]


class PlanResponse(BaseModel):
    request_id: str
    plan_id: str = Field(description="names this plan and its candidates in POST /verify")
    candidates: list[Candidate]
    models: dict[str, str] = Field(description="model reference -> version used")
    timing: dict[str, float]


class SkillVersion(BaseModel):
    name: str
    version: str
    ready: bool
    detail: str = ""


class SkillSummary(BaseModel):
    name: str
    versions: list[SkillVersion]
    aliases: dict[str, str] = Field(default_factory=dict)


class VerifyRequest(BaseModel):
    """Either a plan with its candidates, or the id of a plan this service returned."""

    plan: dict[str, Any] | None = Field(None, description="the plan JSON (as for POST /plan)")
    candidates: list[dict[str, Any]] | None = Field(None, description="candidates as POST /plan returns them")
    plan_id: str | None = Field(None, description="a plan_id from POST /plan: verify its candidates")
    top_k: int | None = Field(None, ge=1, description="verify only the best k candidates")
    seed: int = Field(0, ge=0, description="simulator seed")
    max_attempts: int = Field(3, ge=1, le=10, description="workers that may try before the job fails")


class JobAccepted(BaseModel):
    job_id: str
    status: str
    url: str


class JobView(BaseModel):
    id: str
    kind: str
    status: str
    attempts: int
    max_attempts: int
    worker: str | None
    result: dict[str, Any] | None
    error: str | None
    created_at: float
    updated_at: float
