"""What executing a step or a plan reports: success, or a failure type with its reason."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from enum import IntEnum
from typing import Any


class FailureType(IntEnum):
    """The paper's failure classes (appendix, "Failure cases")."""

    METHOD = 1  # no IK solution, or the skill's precondition does not hold
    PATH = 2  # no collision-free path (the goal configuration collides, or the planner gave up)
    PHYSICS = 3  # the simulator disagreed: dropped, slipped, knocked over, missed


class SkillFailure(Exception):
    """Raised inside an executor; ``execute_plan`` turns it into a failed ``StepOutcome``."""

    def __init__(self, failure_type: FailureType, reason: str) -> None:
        super().__init__(reason)
        self.failure_type = failure_type
        self.reason = reason


@dataclass
class StepTimings:
    wall_s: float = 0.0
    planning_s: float = 0.0
    physics_steps: int = 0


@dataclass
class StepOutcome:
    step: int
    skill: str
    robot: str
    success: bool
    failure_type: int | None
    reason: str
    poses: dict[str, list[float]]  # entity -> world pose [x, y, z, qx, qy, qz, qw]; robots: end effector
    grippers: dict[str, float]  # robot -> finger opening in metres
    timings: StepTimings = field(default_factory=StepTimings)

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class PlanOutcome:
    steps: list[StepOutcome]
    goal_satisfied: bool
    goal_report: list[str]
    wall_s: float
    physics_steps: int

    @property
    def success(self) -> bool:
        """Every step succeeded and the goal holds in the simulator afterwards."""
        return all(s.success for s in self.steps) and self.goal_satisfied

    @property
    def first_failure(self) -> StepOutcome | None:
        return next((s for s in self.steps if not s.success), None)

    def to_json(self) -> dict[str, Any]:
        out = asdict(self)
        out["success"] = self.success
        return out
