"""Response schemas of the HTTP API (separate from the library's internal structures)."""

from __future__ import annotations

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
    model: str
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
