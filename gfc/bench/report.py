"""What ``gfc bench tasks`` writes: the markdown report, the top-1 bar plot and key frames."""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gfc.bench.goals import verdict_markdown
from gfc.bench.tasks import FAILURE_TYPES, BenchResult, Trial, to_arrays
from gfc.tasks import sample_task

# Which method's trial shows a task's key frames when several qualify: the method under test first.
FRAME_PREFERENCE = ("gfc", "linear_chain", "independent", "random", "reference")


@dataclass(frozen=True)
class KeyFrameStrip:
    task: str
    method: str
    seed: int
    success: bool  # as recorded by the benchmark
    replayed_success: bool  # as seen again while rendering (execution is deterministic)
    path: Path


def _pct(value: float) -> str:
    return f"{100 * value:.0f}%"


def _reason_key(reason: str) -> str:
    """A failure reason with its numbers masked: the same failure at another pose or distance."""
    return _NUMBER.sub("#", reason)


_NUMBER = re.compile(r"-?\d+(\.\d+)?")
REASONS_SHOWN = 6  # per task and method
SEEDS_SHOWN = 5


def failure_reasons_markdown(trials: Sequence[Trial], methods: Sequence[str] = ("gfc",)) -> list[str]:
    """The commonest top-1 failures of ``methods`` per task, by step, skill and reason (numbers
    masked), with their count, type and a few seeds: what the failure tables' counts are."""
    lines = [
        "## Commonest top-1 failures",
        "",
        "Per task and method, the first failures of the top-1 executions grouped by step and reason"
        " (numbers shown as #), with a few of their seeds; 'goal' is every step done and the goal"
        " not holding.",
    ]
    groups: dict[tuple[str, str], dict[tuple[int, str, str, int], list[int]]] = {}
    for trial in trials:
        if trial.method not in methods or trial.result.top1_success:
            continue
        failure = trial.result.top1_failure
        key = (
            (-1, "", "goal", 0)
            if failure is None
            else (failure.step, failure.skill, _reason_key(failure.reason), failure.failure_type)
        )
        groups.setdefault((trial.task, trial.method), {}).setdefault(key, []).append(trial.seed)
    for (task, method), reasons in groups.items():
        lines += [
            "",
            f"### {task}, {method}",
            "",
            "| count | step | type | reason | seeds |",
            "| --- | --- | --- | --- | --- |",
        ]
        ranked = sorted(reasons.items(), key=lambda item: (-len(item[1]), item[0]))
        for (step, skill, reason, kind), seeds in ranked[:REASONS_SHOWN]:
            where = "-" if step < 0 else f"{step} {skill}"
            shown = ", ".join(str(s) for s in sorted(seeds)[:SEEDS_SHOWN]) + (
                ", ..." if len(seeds) > SEEDS_SHOWN else ""
            )
            lines.append(f"| {len(seeds)} | {where} | {kind or '-'} | {reason.replace('|', '/')} | {shown} |")
        rest = sum(len(s) for _, s in ranked[REASONS_SHOWN:])
        if rest:
            lines.append(f"| {rest} | | | other reasons | |")
    return lines


def results_markdown(
    summary: dict[str, Any],
    command: str,
    notes: Sequence[str] = (),
    frames: Sequence[KeyFrameStrip] = (),
    markdown_path: Path | None = None,
    reasons: Sequence[str] = (),
) -> str:
    """The report: task x method table, per-task failure breakdowns, the commonest failure
    reasons (``failure_reasons_markdown``), key frames, the command."""
    tasks: dict[str, dict[str, Any]] = summary["tasks"]
    lines = ["# Task benchmark", ""]
    lines += [f"Produced by `{command}`.", ""]
    lines += [f"- {note}" for note in notes]
    if notes:
        lines.append("")
    lines += [
        "top-1: the best-ranked candidate executed once; any-5: the top five tried in turn, each in a "
        "fresh world. Success: every step succeeds and the goal holds in the simulator afterwards.",
        "",
        "'unscreened': trials where no candidate passed the kinematic screen, so the method's own "
        "best, unscreened, was executed; 'redrawn': trials that drew more than one round of candidates "
        "because none of the first passed the screen (`--rounds`) ('-': the log does not say).",
        "",
        "| task | method | top-1 | any-5 | trials | unscreened | redrawn | median planning time (s) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for task, methods in tasks.items():
        for method, row in methods.items():
            fallbacks, redrawn = row.get("screen_fallbacks"), row.get("redrawn")
            lines.append(
                f"| {task} | {method} | {_pct(row['top1'])} | {_pct(row['any5'])} | {row['trials']} "
                f"| {'-' if fallbacks is None else fallbacks} | {'-' if redrawn is None else redrawn} "
                f"| {row['plan_seconds_median']:.3f} |"
            )
    lines += ["", *verdict_markdown(summary)]
    lines += [
        "## Failures of the top-1 executions",
        "",
        "Per step, the trials whose first failure was that step, by type (1: no IK solution or "
        "precondition violated; 2: no collision-free path; 3: physics), as `type1/type2/type3`; a "
        "group's failure counts at its first step. 'goal not met': every step succeeded, the goal "
        "did not hold.",
    ]
    for task, methods in tasks.items():
        names = list(methods)
        lines += ["", f"### {task}", ""]
        lines.append("| step | " + " | ".join(names) + " |")
        lines.append("| --- |" + " --- |" * len(names))
        steps = methods[names[0]]["failures"]["steps"] if names else []
        for i, step in enumerate(steps):
            label = f"{i} {step['skill']} {step['object'] or ''} ({step['robot']})".replace("  ", " ")
            cells = [
                "/".join(str(methods[m]["failures"]["steps"][i][t]) for t in FAILURE_TYPES) for m in names
            ]
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
        for key, title in (("goal_not_met", "goal not met"), ("succeeded", "succeeded")):
            lines.append(f"| {title} | " + " | ".join(str(methods[m]["failures"][key]) for m in names) + " |")
    if reasons:
        lines += ["", *reasons]
    if frames:
        lines += ["", "## Key frames", ""]
        base = markdown_path.parent if markdown_path is not None else Path(".")
        for strip in frames:
            link = Path(os.path.relpath(strip.path, base)).as_posix()
            state = "success" if strip.success else "failure"
            note = "" if strip.replayed_success == strip.success else " (NOT reproduced when replayed)"
            lines.append(
                f"- {strip.task}, top-1 {state}, {strip.method}, seed {strip.seed}{note}: [{link}]({link})"
            )
    lines.append("")
    return "\n".join(lines)


def plot_top1(summary: dict[str, Any], path: Path) -> Path:
    """Grouped bars: top-1 success per task (groups) and method (bars)."""
    import matplotlib

    matplotlib.use("Agg")  # files only: no display on the machines this runs on
    import matplotlib.pyplot as plt

    tasks: dict[str, dict[str, Any]] = summary["tasks"]
    names = list(tasks)
    methods = list(dict.fromkeys(m for row in tasks.values() for m in row))
    width = 0.8 / max(1, len(methods))
    fig, ax = plt.subplots(figsize=(max(6.0, 1.3 * len(names) + 2), 4.0))
    for j, method in enumerate(methods):
        xs = [i + (j - (len(methods) - 1) / 2) * width for i in range(len(names))]
        ys = [100 * tasks[t][method]["top1"] if method in tasks[t] else 0.0 for t in names]
        ax.bar(xs, ys, width, label=method)
    ax.set_xticks(range(len(names)))
    ax.set_xticklabels(names, rotation=30, ha="right")
    ax.set_ylabel("top-1 success (%)")
    ax.set_ylim(0, 100)
    ax.legend(fontsize="small")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _pick(trials: Sequence[Trial], success: bool) -> Trial | None:
    order = {m: i for i, m in enumerate(FRAME_PREFERENCE)}
    matching = [t for t in trials if t.result.top1_success == success]
    return min(matching, key=lambda t: (order.get(t.method, len(order)), t.seed), default=None)


def render_key_frames(result: BenchResult, folder: Path) -> list[KeyFrameStrip]:
    """Replay one successful and one failed top-1 trial per task (where there is one) with a
    frame after each stage; saves ``TASK_top1_success.png`` / ``TASK_top1_failure.png`` strips."""
    from gfc.sim.execute import execute_plan
    from gfc.sim.render import KeyFrames, save_strip

    strips = []
    for task in result.tasks:
        trials = [t for t in result.trials if t.task == task]
        for success in (True, False):
            trial = _pick(trials, success)
            if trial is None:
                continue
            instance = sample_task(task, trial.seed)
            frames = KeyFrames()
            outcome = execute_plan(
                instance.plan,
                to_arrays(trial.top1_actions),
                seed=trial.seed,
                contents=instance.contents,
                on_stage=frames.record,
            )
            path = folder / f"{task}_top1_{'success' if success else 'failure'}.png"
            path.parent.mkdir(parents=True, exist_ok=True)
            save_strip([img for _, img in frames.frames], [c for c, _ in frames.frames], path)
            strips.append(KeyFrameStrip(task, trial.method, trial.seed, success, outcome.success, path))
    return strips
