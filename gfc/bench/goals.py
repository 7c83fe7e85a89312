"""The bars the task benchmark is held to: the paper's GFC success (100 trials) and our goals."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

Z_95 = 1.959964  # two-sided 95 % normal quantile


@dataclass(frozen=True)
class Bar:
    paper_gfc: float  # the paper's table, GFC, 100 trials
    goal: float  # ours (the issues: bimanual #6, single-arm #7)


BARS: dict[str, Bar] = {
    "hammer_place": Bar(0.63, 0.90),
    "pour_cup": Bar(0.41, 0.85),
    "hammer_nail": Bar(0.34, 0.70),
    "pot_reorientation": Bar(0.53, 0.80),
    "hammer_nail_v1": Bar(0.24, 0.55),
    "hammer_nail_v2": Bar(0.25, 0.55),
    "hammer_nail_v3": Bar(0.21, 0.55),
    "hook_reach_t1": Bar(0.82, 0.90),
    "hook_reach_t2": Bar(0.82, 0.90),
    "hook_reach_t3": Bar(0.80, 0.90),
    "rearrangement_push_t1": Bar(0.68, 0.60),
    "rearrangement_push_t2": Bar(0.65, 0.60),
    "rearrangement_push_t3": Bar(0.25, 0.60),
    "constrained_packing_t1": Bar(0.75, 0.90),
    "constrained_packing_t2": Bar(1.0, 0.90),
    "constrained_packing_t3": Bar(1.0, 0.90),
}


def _pct(value: float) -> str:
    return f"{100 * value:.0f}%"


def wilson_interval(successes: int, trials: int, z: float = Z_95) -> tuple[float, float]:
    """Wilson score interval of a success rate (95 % by default): unlike the normal
    approximation it stays inside [0, 1] and is sane at 0 or n successes."""
    if trials <= 0:
        return (0.0, 1.0)
    p = successes / trials
    denominator = 1.0 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denominator
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denominator
    low = 0.0 if successes == 0 else max(0.0, centre - half)  # exact at the ends (no rounding)
    high = 1.0 if successes == trials else min(1.0, centre + half)
    return (low, high)


def verdicts(summary: dict[str, Any], method: str = "gfc") -> list[dict[str, Any]]:
    """Per task with a bar: ``method``'s top-1 against the paper, our goal and the best baseline."""
    out = []
    for task, methods in summary["tasks"].items():
        bar = BARS.get(task)
        if bar is None or method not in methods:
            continue
        ours, n = methods[method]["top1"], methods[method]["trials"]
        baselines = {m: row["top1"] for m, row in methods.items() if m not in (method, "reference")}
        best = max(baselines.items(), key=lambda kv: kv[1], default=None)
        out.append(
            {
                "task": task,
                "top1": ours,
                "trials": n,
                "top1_ci95": wilson_interval(round(ours * n), n),
                "paper_gfc": bar.paper_gfc,
                "goal": bar.goal,
                "beats_paper": ours >= bar.paper_gfc,
                "meets_goal": ours >= bar.goal,
                "best_baseline": None if best is None else {"method": best[0], "top1": best[1]},
                "above_baselines": best is None or ours > best[1],
            }
        )
    return out


def verdict_markdown(summary: dict[str, Any], method: str = "gfc") -> list[str]:
    rows = verdicts(summary, method)
    if not rows:
        return []
    lines = [
        "## Against the paper and our goals",
        "",
        f"Top-1 of `{method}` here, with its 95 % interval (Wilson); the paper's GFC column is its "
        "100-trial table. A row that misses says so; the failure tables below say at which step and "
        "of which type.",
        "",
        "| task | ours (top-1) | 95 % interval | trials | paper GFC | goal | >= paper | >= goal | best baseline | above it |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        best = r["best_baseline"]
        best_cell = "none run" if best is None else f"{best['method']} {_pct(best['top1'])}"
        lines.append(
            f"| {r['task']} | {_pct(r['top1'])} | {100 * r['top1_ci95'][0]:.0f}-{_pct(r['top1_ci95'][1])} "
            f"| {r['trials']} | {_pct(r['paper_gfc'])} | {_pct(r['goal'])} "
            f"| {'yes' if r['beats_paper'] else 'MISSED'} | {'yes' if r['meets_goal'] else 'MISSED'} "
            f"| {best_cell} | {'yes' if r['above_baselines'] else 'NO'} |"
        )
    return [*lines, ""]
