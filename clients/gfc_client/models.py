"""Typed responses of the gfc service (pydantic v2). Unknown fields are kept, not refused, so an
older SDK keeps working against a newer service."""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from pydantic import BaseModel, ConfigDict, Field


class _Model(BaseModel):
    model_config = ConfigDict(extra="allow")


class Issue(_Model):
    loc: str = Field(description="where: a JSON path such as skeleton[2].from")
    message: str = Field(description="what is wrong and what to do")


# ---- POST /plan ----------------------------------------------------------------------------


class StepParameters(_Model):
    step: int
    skill: str
    model: str | None = Field(
        None, description="skill model sampled (none for a terminal skill such as strike)"
    )
    action: list[float] = Field(description="raw action vector")
    action_named: dict[str, float] | None = None
    action_pose: list[float] | None = Field(None, description="pose actions as [x, y, z, qx, qy, qz, qw]")


class NodeState(_Model):
    pose: list[float] = Field(description="[x, y, z, qx, qy, qz, qw], world frame")
    gripper: float | None = None


class Residual(_Model):
    type: str
    source: str
    index: int
    max_scaled_residual: float
    satisfied: bool


class Candidate(_Model):
    rank: int
    cost: float = Field(description="spatial energy of constraints and goal; lower is better")
    steps: list[StepParameters]
    nodes: dict[str, NodeState]
    residuals: list[Residual]

    @property
    def satisfied(self) -> bool:
        """Every constraint and goal term within its tolerance."""
        return all(r.satisfied for r in self.residuals)


class PlanResponse(_Model):
    request_id: str
    plan_id: str = Field(description="names this plan's candidates in verify(plan_id=...)")
    candidates: list[Candidate]
    models: dict[str, str] = Field(description="model reference -> version used")
    timing: dict[str, float]

    @property
    def best(self) -> Candidate:
        """The lowest-cost candidate."""
        if not self.candidates:
            raise ValueError("the response has no candidates")
        return min(self.candidates, key=lambda c: c.rank)


# ---- POST /verify, GET /jobs/{id} ----------------------------------------------------------


class JobStatus(StrEnum):
    QUEUED = "queued"
    RUNNING = "running"
    SUCCEEDED = "succeeded"
    FAILED = "failed"


class JobAccepted(_Model):
    job_id: str
    status: JobStatus
    url: str


class StepOutcome(_Model):
    step: int
    skill: str
    robot: str
    success: bool
    failure_type: int | None = Field(None, description="1 no IK/precondition, 2 no path, 3 physics")
    reason: str = ""


class CandidateOutcome(_Model):
    rank: int
    success: bool
    goal_satisfied: bool | None = None
    goal_report: list[str] = Field(default_factory=list)
    steps: list[StepOutcome] = Field(default_factory=list)
    wall_s: float | None = None
    frames: list[str] = Field(default_factory=list, description="names for get_frame(job_id, name)")
    error: str | None = None


class VerifyResult(_Model):
    candidates: list[CandidateOutcome]
    any_success: bool
    first_successful_rank: int | None = None


class Job(_Model):
    id: str
    kind: str
    status: JobStatus
    attempts: int
    max_attempts: int
    worker: str | None = None
    result: dict[str, Any] | None = None
    error: str | None = None
    created_at: float
    updated_at: float

    @property
    def done(self) -> bool:
        return self.status in (JobStatus.SUCCEEDED, JobStatus.FAILED)

    @property
    def verification(self) -> VerifyResult | None:
        """The result of a finished verification job, typed; None before it finishes."""
        if self.kind != "verify" or self.result is None:
            return None
        return VerifyResult.model_validate(self.result)


# ---- GET /skills, health -------------------------------------------------------------------


class SkillVersion(_Model):
    name: str
    version: str
    ready: bool
    detail: str = ""


class Skill(_Model):
    name: str
    versions: list[SkillVersion]
    aliases: dict[str, str] = Field(default_factory=dict)


class Health(_Model):
    status: str


class Readiness(_Model):
    """GET /health/ready; ``ready`` is False (not an exception) when the service answers 503."""

    status: str
    ready: bool = False
    reason: str | None = None
    skills: int | None = None
