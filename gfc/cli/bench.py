"""``gfc bench ...``: benchmarks that print a table and write it under docs/."""

from __future__ import annotations

import json
import shlex
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import Progress, TaskID

bench_app = typer.Typer(
    help="Benchmarks: print a table, write it (and JSON) under docs/.", no_args_is_help=True
)


def phase_logger(progress: Progress, bar: TaskID, console: Console) -> Callable[[str, int], None]:
    """Advance the bar; when the output is not a terminal (a log file, CI), where the bar does
    not show, print a line whenever the phase changes, with how far the run has come."""
    last: list[str] = []

    def on_progress(msg: str, n: int) -> None:
        progress.update(bar, advance=n, description=msg)
        if not console.is_terminal and (not last or last[-1] != msg):
            last.append(msg)
            state = next(t for t in progress.tasks if t.id == bar)
            console.print(f"{msg} ({int(state.completed)}/{int(state.total or 0)} units done)")

    return on_progress


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


def _names(values: list[str] | None) -> list[str]:
    """Repeated options and comma-separated lists alike: ``--tasks a,b --tasks c``."""
    return [n.strip() for v in values or [] for n in v.split(",") if n.strip()]


@bench_app.command()
def tasks(
    task_names: Annotated[
        list[str] | None,
        typer.Option("--tasks", help="tasks (repeat or comma-separate; default: every registered task)"),
    ] = None,
    method_names: Annotated[
        list[str] | None,
        typer.Option(
            "--methods",
            help="gfc, independent, linear_chain, random (default: these four); reference (an oracle)",
        ),
    ] = None,
    trials: Annotated[int, typer.Option(min=1, help="scenes per task (the same for every method)")] = 100,
    candidates: Annotated[int, typer.Option(min=5, help="candidates sampled per trial (any-5 needs 5)")] = 10,
    steps: Annotated[int, typer.Option(min=1, help="reverse diffusion steps")] = 50,
    json_file: Annotated[
        Path | None, typer.Option("--json", help="also write the results as JSON here")
    ] = None,
    out: Annotated[Path, typer.Option(help="where the markdown report goes")] = Path("docs/results.md"),
    plot: Annotated[Path | None, typer.Option(help="top-1 bar plot (PNG; default: next to --out)")] = None,
    frames: Annotated[
        bool,
        typer.Option("--frames/--no-frames", help="key frames of one top-1 success and failure per task"),
    ] = True,
    processes: Annotated[int, typer.Option(min=1, help="simulator processes")] = 2,
    seed: Annotated[int, typer.Option(min=0, help="first scene seed; trial i uses seed + i")] = 0,
    skills: Annotated[
        str | None, typer.Option(help="skill store location (default: the packaged library)")
    ] = None,
    random_weights: Annotated[
        bool,
        typer.Option(help="randomly initialised models instead of the store: checks the plumbing only"),
    ] = False,
    threads: Annotated[int, typer.Option(min=1, help="torch CPU threads for planning")] = 1,
    screen: Annotated[
        bool,
        typer.Option(
            "--screen/--no-screen",
            help="re-rank every method's candidates by the kinematic screen (gfc.sim.screen): "
            "those whose poses the arms can reach go first",
        ),
    ] = True,
    rounds: Annotated[
        int,
        typer.Option(
            min=1,
            help="sampling rounds: while no candidate drawn so far passes the screen, draw --candidates "
            "more with a fresh seed, up to this many draws in all (every method alike)",
        ),
    ] = 1,
    ray: Annotated[
        str | None, typer.Option(help="Ray address for the simulations (default: local processes)")
    ] = None,
    log: Annotated[
        Path | None,
        typer.Option(
            help="resumable trial log (JSON lines): trials already in it are reused, new ones "
            "appended as they finish; rerun the same command to continue an interrupted run"
        ),
    ] = None,
    report_only: Annotated[
        bool,
        typer.Option(
            "--report-only",
            help="plan and run nothing: write the report from the trials --log holds (up to --trials "
            "per task and method; each row says how many it has)",
        ),
    ] = False,
    plan_in_workers: Annotated[
        bool,
        typer.Option(
            "--plan-in-workers/--plan-here",
            help="each simulator process plans and executes whole trials, so every core plans "
            "(the default; the same trials); --plan-here plans in this process while the pool "
            "executes (gfc/bench/parallel.py says why)",
        ),
    ] = True,
    pipeline: Annotated[
        bool,
        typer.Option(
            "--pipeline/--no-pipeline",
            help="plan the next chunk of trials while the simulator processes execute this one "
            "(the same trials either way; --no-pipeline takes turns, as before session 9)",
        ),
    ] = True,
) -> None:
    """Success rates on the simulated tasks: top-1 and any-5 per task and method, failures by step
    and type, median planning time. Writes the markdown report (with the command), the JSON, a
    bar plot and key frames; see gfc/bench/tasks.py for what each number means."""
    import torch
    from rich.table import Table

    from gfc.bench.methods import METHODS, MissingModelsError, PlanSettings, needs_models
    from gfc.bench.parallel import LibrarySpec, run_benchmark_in_workers
    from gfc.bench.report import failure_reasons_markdown, plot_top1, render_key_frames, results_markdown
    from gfc.bench.tasks import random_weights_library, run_benchmark, summarise
    from gfc.bench.trial_log import TrialLog, log_header
    from gfc.planner.library import SkillLibrary
    from gfc.pool import make_pool
    from gfc.tasks import ALL_TASKS

    console = Console()
    torch.set_num_threads(threads)
    names = _names(task_names) or list(ALL_TASKS)
    methods = _names(method_names) or list(METHODS)
    library: SkillLibrary | None
    spec: LibrarySpec | None = None  # the same models, described for the workers
    if not any(needs_models(m) for m in methods):
        library, source = None, "skill models: none (these methods use none)"
    elif random_weights:
        library, spec = random_weights_library(names), LibrarySpec(random_for=tuple(names))
        source = "skill models: **random weights** (a plumbing check: these success rates mean nothing)"
    else:
        from skill_store import DEFAULT_LIBRARY, SkillStore, StoreLibrary

        store = SkillStore(skills or DEFAULT_LIBRARY)
        library, spec = StoreLibrary(store), LibrarySpec(store=str(store.location))
        source = f"skill models: the skill store at `{store.location}` (latest version of each)"
    settings = PlanSettings(candidates=candidates, steps=steps, screen=screen, rounds=rounds)
    total = 2 * len(names) * len(methods) * trials
    if report_only and log is None:
        console.print("[red]error:[/red] --report-only reads the trials from a log: give it with --log FILE")
        raise typer.Exit(2)
    pool = make_pool(ray, processes, keep_alive=True)
    try:
        trial_log = None
        if log is not None:
            weights = "random" if random_weights else "store"
            header = log_header(names, methods, library, settings, threads, weights)
            trial_log = TrialLog(log, header, reading_only=report_only)
            console.print(f"trial log {log}: {len(trial_log)} trials recorded")
        with Progress(console=console, transient=True) as progress:
            bar = progress.add_task("starting", total=total)
            if plan_in_workers and not report_only:
                result = run_benchmark_in_workers(
                    names,
                    methods,
                    trials,
                    spec,
                    pool,
                    settings,
                    threads=threads,
                    seed=seed,
                    on_progress=phase_logger(progress, bar, console),
                    log=trial_log,
                )
            else:
                result = run_benchmark(
                    names,
                    methods,
                    trials,
                    library,
                    pool,
                    settings,
                    seed=seed,
                    on_progress=phase_logger(progress, bar, console),
                    log=trial_log,
                    execute=not report_only,
                    pipeline=pipeline,
                )
    except (MissingModelsError, KeyError, ValueError) as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from None
    finally:
        close = getattr(pool, "close", None)
        if close is not None:
            close()
    summary = summarise(result)
    strips = render_key_frames(result, out.parent / out.stem) if frames else []
    # The exact command line when run as `gfc bench tasks ...`; not invented when called otherwise.
    argv = sys.argv[1:]
    command = (
        "gfc " + " ".join(shlex.quote(a) for a in argv)
        if argv[:2] == ["bench", "tasks"]
        else "gfc bench tasks (invoked from Python; command line unknown)"
    )
    notes = [
        source,
        f"{trials} scenes per task (seeds {seed}..{seed + trials - 1}), {candidates} candidates, "
        f"{steps} sampling steps, {threads} torch thread(s)",
        "kinematic screen: "
        + (
            "on (every method's candidates re-ranked: reachable without collision first; gfc/sim/screen.py)"
            + (f"; up to {rounds} draws of {candidates} while none passes" if rounds > 1 else "")
            if screen
            else "off (candidates in each method's own order)"
        ),
    ]
    if trial_log is not None:
        notes.append(
            f"trial log: `{log}` (code fingerprint {trial_log.header['code']}; {len(trial_log)} trials in it)"
            + ("; **report only**: nothing was run for this report" if report_only else "")
            + ("" if trial_log.code_matches else "; the trials were made by other code than this checkout's")
        )
    plot_path = plot or out.parent / out.stem / "top1.png"
    plot_top1(summary, plot_path)
    notes.append(
        f"plot: [{plot_path.name}]({plot_path.relative_to(out.parent).as_posix()})"
        if plot_path.is_relative_to(out.parent)
        else f"plot: {plot_path}"
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    reasons = failure_reasons_markdown(result.trials, [m for m in ("gfc",) if m in methods])
    out.write_text(results_markdown(summary, command, notes, strips, out, reasons))
    if json_file is not None:
        json_file.parent.mkdir(parents=True, exist_ok=True)
        json_file.write_text(json.dumps(summary, indent=2) + "\n")
    table = Table(title="task benchmark (top-1 / any-5)")
    for column in ("task", "method", "top-1", "any-5", "trials", "plan s (median)"):
        table.add_column(column)
    for task, by_method in summary["tasks"].items():
        for method, row in by_method.items():
            table.add_row(
                task,
                method,
                f"{100 * row['top1']:.0f}%",
                f"{100 * row['any5']:.0f}%",
                str(row["trials"]),
                f"{row['plan_seconds_median']:.3f}",
            )
    console.print(table)
    console.print(f"wrote {out}" + (f", {json_file}" if json_file else "") + f", {plot_path}")


@bench_app.command()
def standing(
    logs: Annotated[
        list[Path],
        typer.Argument(help="trial logs (from `gfc bench tasks --log`), oldest first", show_default=False),
    ],
    trials: Annotated[int, typer.Option(min=1, help="trials a complete row has")] = 100,
    into: Annotated[
        Path | None,
        typer.Option(
            help="replace the standing block of this markdown file (between the markers "
            "`<!-- standing:start ...-->` and `<!-- standing:end -->`) with the table"
        ),
    ] = None,
) -> None:
    """Where every task's row stands: per task the log with the most GFC trials, every method's
    top-1 from that one log, the paper and our goal, and whether the log was made by this code.

    Runs nothing; reads the logs. Name them oldest first (a shell glob sorts by name, not by
    age); the command under the table at the top of docs/results.md lists the project's logs
    in order, e.g. `gfc bench standing docs/bench/trials/single_arm_s24.jsonl
    docs/bench/trials/packing_s26.jsonl --into docs/results.md`.
    """
    from gfc.bench.standing import read_log, replace_block, select_standing, standing_markdown
    from gfc.bench.trial_log import code_fingerprint

    console = Console()
    try:
        standings = select_standing([read_log(p) for p in logs], trials)
        table = standing_markdown(standings, trials, code_fingerprint(), root=Path.cwd())
        if into is not None:
            try:
                text = into.read_text(encoding="utf-8")
            except OSError as exc:
                raise ValueError(f"{into}: cannot read it ({exc.strerror})") from None
            command = "gfc bench standing " + " ".join(shlex.quote(p.as_posix()) for p in logs)
            if trials != 100:
                command += f" --trials {trials}"
            block = f"Made by `{command} --into {shlex.quote(into.as_posix())}`.\n\n{table}"
            into.write_text(replace_block(text, block, where=str(into)), encoding="utf-8")
    except ValueError as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from None
    sys.stdout.write(table)  # plain: a markdown table must not be wrapped to the terminal
