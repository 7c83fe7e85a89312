"""Verification jobs: execute plan candidates in the simulator, report per step, render frames."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gfc.plan import parse_plan
from gfc.pool import Pool

VERIFY_KIND = "verify"


@dataclass(frozen=True)
class CandidateRun:
    """One candidate to execute (plain data: it crosses process boundaries)."""

    plan: dict[str, Any]
    candidate: dict[str, Any]
    seed: int
    frames_dir: str | None
    frames_url: str | None = None  # where the service serves frames_dir (``/jobs/{id}/frames``)


def run_candidate(run: CandidateRun) -> dict[str, Any]:
    """Execute one candidate in a fresh world; key frames go to ``frames_dir`` when given."""
    from gfc.sim.candidates import Candidate, candidate_actions
    from gfc.sim.execute import execute_plan
    from gfc.sim.render import render, save_strip

    plan = parse_plan(run.plan)
    candidate = Candidate.model_validate(run.candidate)
    try:
        actions = candidate_actions(plan, candidate)
    except ValueError as exc:
        return {"rank": candidate.rank, "success": False, "error": str(exc), "steps": []}
    images: list[Any] = []
    captions: list[str] = []

    def key_frame(world: Any, caption: str) -> None:
        images.append(render(world))
        captions.append(caption)

    outcome = execute_plan(plan, actions, seed=run.seed, on_stage=key_frame if run.frames_dir else None)
    frames: list[str] = []
    if run.frames_dir and images:
        path = Path(run.frames_dir) / f"rank{candidate.rank}.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        save_strip(images, captions, path)
        frames.append(f"{run.frames_url}/{path.name}" if run.frames_url else path.name)
    return {
        "rank": candidate.rank,
        "success": outcome.success,
        "goal_satisfied": outcome.goal_satisfied,
        "goal_report": outcome.goal_report,
        "steps": [
            {
                "step": s.step,
                "skill": s.skill,
                "robot": s.robot,
                "success": s.success,
                "failure_type": s.failure_type,
                "reason": s.reason,
            }
            for s in outcome.steps
        ],
        "wall_s": outcome.wall_s,
        "frames": frames,
    }


def verify_payload(
    payload: dict[str, Any], pool: Pool, frames_root: Path | None, job_id: str
) -> dict[str, Any]:
    """A verify job's result: every candidate executed (in parallel over ``pool``)."""
    frames_dir = None if frames_root is None else str(frames_root / job_id)
    runs = [
        CandidateRun(
            payload["plan"], candidate, int(payload.get("seed", 0)), frames_dir, f"/jobs/{job_id}/frames"
        )
        for candidate in payload["candidates"]
    ]
    results = pool.map(run_candidate, runs)
    best = next((r["rank"] for r in sorted(results, key=lambda r: r["rank"]) if r["success"]), None)
    return {"candidates": results, "any_success": best is not None, "first_successful_rank": best}
