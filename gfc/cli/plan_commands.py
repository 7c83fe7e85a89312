"""``gfc validate``: check a plan and show the factor graph it compiles to."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from gfc.plan import PlanError, compile_plan, load_plan
from gfc.plan.graph import CompiledPlan

EXIT_INVALID = 2


def print_summary(console: Console, compiled: CompiledPlan) -> None:
    summary = compiled.summary()
    console.print(
        f"[bold green]valid[/]: {len(compiled.temporal)} steps in {len(compiled.stages)} stages, "
        f"{len(compiled.nodes)} node versions ({len(summary['known_nodes'])} known, "
        f"{len(summary['free_nodes'])} sampled), {len(compiled.actions)} actions, "
        f"{len(compiled.spatial)} spatial factor{'' if len(compiled.spatial) == 1 else 's'}"
    )
    table = Table(title="temporal factors (one per skeleton step)")
    for col in ("step", "model", "robot", "group", "pre nodes", "effect nodes"):
        table.add_column(col)
    for f in summary["temporal_factors"]:
        table.add_row(
            str(f["step"]),
            f["model"],
            f["robot"],
            f["group"] or "",
            ", ".join(f["pre"]),
            ", ".join(f["effect"]),
        )
    console.print(table)
    if summary["spatial_factors"]:
        spatial = Table(title="spatial factors (constraints, goal, and those the compiler implies)")
        for col in ("source", "type", "nodes"):
            spatial.add_column(col)
        for s in summary["spatial_factors"]:
            spatial.add_row(f"{s['source']}[{s['index']}]", s["type"], ", ".join(s["nodes"]))
        console.print(spatial)
    console.print(f"known nodes: {', '.join(summary['known_nodes'])}")
    console.print(
        f"nodes shared by two or more skills (compensated): {', '.join(summary['shared_nodes']) or 'none'}"
    )


def register_plan_commands(app: typer.Typer) -> None:
    @app.command()
    def validate(
        plan_file: Annotated[
            Path, typer.Argument(help="plan JSON: scene, skeleton, constraints, goal, options")
        ],
        as_json: Annotated[
            bool, typer.Option("--json", help="print the compiled graph (or the errors) as JSON")
        ] = False,
    ) -> None:
        """Check a plan and print the factor graph it compiles to.

        Exits 0 with a summary of the graph: node versions (hammer@0 is the hammer before any
        skill, hammer@2 after the second skill that touches it), temporal factors (one per
        step), spatial factors and known nodes. Exits 2 listing every error with its location,
        for example ``skeleton[2].from: robot 'left' does not hold 'hammer'``.

        Example: gfc validate gfc/examples/hammer_place.json
        """
        console = Console()
        if not plan_file.is_file():
            console.print(f"[red]error[/]: {plan_file} does not exist or is not a file")
            raise typer.Exit(EXIT_INVALID)
        try:
            compiled = compile_plan(load_plan(plan_file))
        except PlanError as exc:
            if as_json:
                print(json.dumps({"valid": False, "errors": exc.to_json()}, indent=2))
            else:
                console.print(f"[bold red]invalid plan[/] {plan_file}: {len(exc.issues)} problem(s)")
                for issue in exc.issues:
                    console.print(f"  [red]{issue.loc}[/]: {issue.message}", highlight=False)
            raise typer.Exit(EXIT_INVALID) from None
        if as_json:
            print(json.dumps({"valid": True, **compiled.summary()}, indent=2))
        else:
            print_summary(console, compiled)
