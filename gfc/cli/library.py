"""``gfc library build|check``: the default skill library, rebuilt from nothing and checked."""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path
from typing import Annotated

import typer

library_app = typer.Typer(
    help=(
        "The default skill library: every skill model the benchmark tasks need.\n\n"
        "  gfc library build                 # collect, train and publish all of them (about 30 min on 2 cores)\n\n"
        "  gfc library check -n 50           # hit rates in the simulator -> docs/skills.md"
    ),
    no_args_is_help=True,
)


def _store_option() -> str:
    from skill_store import DEFAULT_LIBRARY

    return str(DEFAULT_LIBRARY)


@library_app.command()
def build(
    store: Annotated[str | None, typer.Option(help="skill store to publish into (default: the packaged library)")] = None,
    data: Annotated[Path, typer.Option(help="where the datasets (and loss curves) go")] = Path("data"),
    budget: Annotated[str, typer.Option(help="full (the committed library) or tiny (CI: minutes, poor models)")] = "full",
    only: Annotated[list[str] | None, typer.Option(help="build only these models (repeat)")] = None,
    processes: Annotated[int, typer.Option(min=1, help="simulator processes")] = 2,
    report: Annotated[Path | None, typer.Option(help="JSON with per-model rows and timings")] = None,
    seed: Annotated[int, typer.Option(min=0)] = 0,
    rebuild: Annotated[bool, typer.Option(help="build again even models this build already published, from fresh data (after a scenario or skill change)")] = False,
) -> None:  # fmt: skip
    """Collect each model's data in the simulator, train them all, publish each with alias 'latest'.

    Every model of the default library goes through the same pipeline as `gfc collect` and
    `gfc train`: random scenes, a broad action prior, successes kept; the paper's DiT trained
    with denoising score matching; weights published as bfloat16 with the data hash and metrics.
    All datasets are collected first, then all models train together as stacked networks (one
    optimiser step for every model that shares a token count). Datasets resume shard by shard,
    and models this build already published to the store (same budget and seed) are skipped, so
    an interrupted build can be run again; --rebuild builds them again from fresh data.

    Example: gfc library build --store /tmp/skills --report docs/bench/library_build.json
    """
    from rich.console import Console
    from rich.table import Table

    from gfc.pool import LocalPool
    from gfc.skills.build import BUDGETS, DEFAULT_MODELS, build_library
    from skill_store import SkillStore

    console = Console()
    if budget not in BUDGETS:
        console.print(f"[red]error[/]: unknown budget {budget!r} (have: {', '.join(BUDGETS)})")
        raise typer.Exit(2)
    models = list(only or DEFAULT_MODELS)
    unknown = [m for m in models if m not in DEFAULT_MODELS]
    if unknown:
        console.print(f"[red]error[/]: not in the default library: {', '.join(unknown)}")
        raise typer.Exit(2)
    target = SkillStore(store or _store_option())
    pool = LocalPool(processes, keep_alive=True)
    began = time.perf_counter()
    with pool, console.status("building") as status:

        def say(m: str, what: str) -> None:
            status.update(f"{m}: {what}")
            console.log(f"{m}: {what}")

        result = build_library(models, budget, data, target, pool, seed, say, rebuild=rebuild)
    total = time.perf_counter() - began
    table = Table(
        title=f"library build ({budget}): {total / 60:.1f} min, training {result.train_s / 60:.1f} min"
    )
    for col in ("model", "version", "rows", "data success", "collect s", "train s (share)", "held-out loss"):
        table.add_column(col)
    for b in result.built:
        table.add_row(
            b.model, str(b.version), str(b.rows), f"{b.data_success_rate:.0%}", f"{b.collect_s:.0f}",
            f"{b.train_s:.0f}", f"{b.held_out_loss:.3f}",
        )  # fmt: skip
    console.print(table)
    if result.skipped:
        done = ", ".join(f"{m}@{v}" for m, v in result.skipped.items())
        console.print(f"already built by this build, skipped: {done}")
    if report is not None:
        report.parent.mkdir(parents=True, exist_ok=True)
        machine = f"{platform.machine()}, {processes} simulator processes"
        payload = {
            "budget": budget,
            "total_s": total,
            "train_total_s": result.train_s,  # one stacked training run; each model's train_s is its share
            "machine": machine,
            "models": [b.to_json() for b in result.built],
            "skipped": result.skipped,
        }
        report.write_text(json.dumps(payload, indent=2) + "\n")
        console.print(f"wrote {report}")


@library_app.command()
def check(
    models: Annotated[list[str] | None, typer.Argument(help="models to check (default: the whole default library)")] = None,
    n: Annotated[int, typer.Option("-n", min=1, help="fresh scenes per model")] = 50,
    store: Annotated[str | None, typer.Option(help="skill store (default: the packaged library)")] = None,
    processes: Annotated[int, typer.Option(min=1)] = 2,
    json_out: Annotated[Path | None, typer.Option("--json", help="write the reports as JSON")] = None,
    out: Annotated[Path | None, typer.Option(help="write a markdown table (e.g. docs/skills.md)")] = None,
) -> None:  # fmt: skip
    """Sample each model's actions for fresh scenes and execute them alone in the simulator.

    Reports the hit rate next to uniform random actions on the same scenes and the data's own
    success rate. Example: gfc library check -n 50 --out docs/skills.md --json docs/skills.json
    """
    from rich.console import Console

    from gfc.pool import LocalPool
    from gfc.skills.build import DEFAULT_MODELS
    from gfc.skills.check import check_model, markdown_table

    console = Console()
    location = store or _store_option()
    reports = []
    with LocalPool(processes, keep_alive=True) as pool:
        for model in models or DEFAULT_MODELS:
            with console.status(f"checking {model} on {n} scenes"):
                reports.append(check_model(model, n, location, pool))
            r = reports[-1]
            console.print(
                f"{model}@{r['version']}: hit rate {r['hit_rate']:.0%} over {r['trials']} "
                f"(uniform random {r['random_hit_rate']:.0%})"
            )
    table = markdown_table(reports)
    console.print(table)
    if json_out is not None:
        json_out.write_text(json.dumps({"reports": reports}, indent=2) + "\n")
    if out is not None:
        command = f"gfc library check -n {n}" + (f" --store {store}" if store else "")
        out.write_text(
            "# Skill models, checked alone in the simulator\n\n"
            f"Produced by `{command} --out {out}` on {platform.machine()} ({processes} processes). "
            "For each model: fresh scenes of its scenario (seeds disjoint from the data's), the "
            "model's action sampled conditioned on the observed pre nodes, executed alone; the same "
            "scenes with uniformly random actions; and the success rate of the collection prior.\n\n" + table
        )
