"""``gfc bench ...``: benchmarks that print a table and write it under docs/."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import Progress

bench_app = typer.Typer(
    help="Benchmarks: print a table, write it (and JSON) under docs/.", no_args_is_help=True
)


@bench_app.command()
def latency(
    json_file: Annotated[
        Path | None, typer.Option("--json", help="also write the raw result as JSON here")
    ] = None,
    markdown: Annotated[Path, typer.Option(help="where the table goes")] = Path("docs/bench/latency.md"),
    repeats: Annotated[int, typer.Option(min=1, help="timed runs per variant")] = 5,
    candidates: Annotated[int, typer.Option(min=1, help="candidates per plan")] = 10,
    steps: Annotated[int, typer.Option(min=1, help="reverse diffusion steps")] = 50,
    threads: Annotated[int, typer.Option(min=1, help="torch CPU threads")] = 1,
) -> None:
    """Planning latency for the 11-step Hammer Nail skeleton: batched vs one call per factor.

    Runs every variant interleaved in one process (so ratios are fair on a busy machine) and
    reports medians. The paper needed 6 s on an A6000 GPU for this plan; our target is under
    0.2 s batched on a 2-core CPU.
    """
    from gfc.bench.latency import VARIANTS, latency_markdown, run_latency

    console = Console()
    with Progress(console=console, transient=True) as progress:
        task = progress.add_task("timing", total=repeats * len(VARIANTS))
        result = run_latency(
            repeats=repeats,
            candidates=candidates,
            steps=steps,
            threads=threads,
            on_progress=lambda msg: progress.update(task, advance=1, description=msg),
        )
    command = "gfc bench latency " + " ".join(sys.argv[3:]) if len(sys.argv) > 3 else "gfc bench latency"
    text = latency_markdown(result, command.strip())
    console.print(text)
    markdown.parent.mkdir(parents=True, exist_ok=True)
    markdown.write_text(text)
    if json_file is not None:
        json_file.parent.mkdir(parents=True, exist_ok=True)
        json_file.write_text(json.dumps(result, indent=2) + "\n")


@bench_app.command()
def load(
    clients: Annotated[int, typer.Option(min=1, max=256, help="concurrent clients")] = 16,
    requests: Annotated[
        int, typer.Option(min=1, max=100_000, help="requests in total (an upper bound)")
    ] = 200,
    duration: Annotated[float, typer.Option(min=1, max=600, help="seconds at most")] = 60.0,
    candidates: Annotated[int, typer.Option(min=1, help="candidates per plan")] = 10,
    steps: Annotated[int, typer.Option(min=1, help="sampling steps per plan")] = 50,
    json_file: Annotated[
        Path | None, typer.Option("--json", help="also write the raw result as JSON here")
    ] = None,
    markdown: Annotated[Path, typer.Option(help="where the table goes")] = Path("docs/bench/load.md"),
) -> None:
    """Many concurrent clients against a real uvicorn on loopback (bounded in count and time):
    throughput, p50/p99 latency and every status code seen. Overload must show up as 503 with
    Retry-After, never as another 5xx."""
    from service.load_bench import load_markdown, run_load

    result = run_load(
        clients=clients, requests=requests, duration_s=duration, candidates=candidates, steps=steps
    )
    command = "gfc bench load " + " ".join(sys.argv[3:])
    text = load_markdown(result, command.strip())
    Console().print(text)
    markdown.parent.mkdir(parents=True, exist_ok=True)
    markdown.write_text(text)
    if json_file is not None:
        json_file.parent.mkdir(parents=True, exist_ok=True)
        json_file.write_text(json.dumps(result, indent=2) + "\n")
