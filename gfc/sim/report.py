"""Human-readable tables of executed plans (``gfc verify``, ``gfc sim demo``)."""

from __future__ import annotations

from rich.console import Console
from rich.table import Table

from gfc.sim.outcome import FailureType, PlanOutcome

FAILURE_NAMES = {
    int(FailureType.METHOD): "1 no IK / precondition",
    int(FailureType.PATH): "2 no collision-free path",
    int(FailureType.PHYSICS): "3 physics",
}


def outcome_table(outcome: PlanOutcome, title: str) -> Table:
    table = Table(title=title, title_justify="left")
    for column in ("step", "skill", "robot", "result", "reason", "wall s", "plan s"):
        table.add_column(column, overflow="fold")
    for s in outcome.steps:
        result = "ok" if s.success else FAILURE_NAMES.get(s.failure_type or 0, "?")
        table.add_row(
            str(s.step),
            s.skill,
            s.robot,
            f"[green]{result}[/]" if s.success else f"[red]{result}[/]",
            s.reason,
            f"{s.timings.wall_s:.2f}",
            f"{s.timings.planning_s:.2f}",
        )
    return table


def print_outcome(console: Console, outcome: PlanOutcome, title: str) -> None:
    console.print(outcome_table(outcome, title))
    for line in outcome.goal_report:
        console.print(f"  goal: {line}")
    verdict = "[green]SUCCESS[/]" if outcome.success else "[red]FAILURE[/]"
    console.print(f"  {verdict}: {outcome.wall_s:.1f} s wall, {outcome.physics_steps} physics steps")
