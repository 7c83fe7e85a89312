"""The candidates file that ``gfc verify`` executes: ranked parameter sets for one plan.

``{"candidates": [{"rank": 0, "steps": [{"step": 0, "skill": "pick", "action": [9 floats]},
...]}, ...]}``; steps without parameters (strike, pour) have ``"action": []``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from gfc.geometry import FloatArray
from gfc.plan.schema import PlanRequest


class CandidateStep(BaseModel):
    model_config = ConfigDict(extra="ignore")

    step: int = Field(ge=0)
    skill: str
    action: list[float] = Field(default_factory=list)


class Candidate(BaseModel):
    model_config = ConfigDict(extra="ignore")

    rank: int = 0
    steps: list[CandidateStep]


class CandidateFile(BaseModel):
    model_config = ConfigDict(extra="ignore")

    candidates: list[Candidate] = Field(min_length=1)


def load_candidates(path: str | Path) -> CandidateFile:
    return CandidateFile.model_validate(json.loads(Path(path).read_text()))


def candidate_actions(plan: PlanRequest, candidate: Candidate) -> list[FloatArray | None]:
    """One action per skeleton step, in skeleton order; checks that the skills match the plan."""
    by_step = {s.step: s for s in candidate.steps}
    actions: list[FloatArray | None] = []
    for i, step in enumerate(plan.skeleton):
        entry = by_step.get(i)
        if entry is None:
            raise ValueError(f"candidate rank {candidate.rank} has no entry for step {i} ({step.skill})")
        if entry.skill != step.skill:
            raise ValueError(
                f"candidate rank {candidate.rank}, step {i}: skill {entry.skill!r} but the plan says {step.skill!r}"
            )
        actions.append(np.asarray(entry.action, dtype=np.float64) if entry.action else None)
    return actions


def candidates_json(actions: list[FloatArray | None], plan: PlanRequest, rank: int = 0) -> dict[str, object]:
    """The file format for one candidate (used to write the tasks' reference actions)."""
    steps = [
        {"step": i, "skill": s.skill, "action": [] if a is None else [float(v) for v in a]}
        for i, (s, a) in enumerate(zip(plan.skeleton, actions, strict=True))
    ]
    return {"rank": rank, "steps": steps}
