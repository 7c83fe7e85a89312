"""``gfc sim ...`` and ``gfc verify``: run plans in the simulator."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from gfc.plan.compiler import PlanError, load_plan
from gfc.plan.schema import PlanRequest
from gfc.sim.candidates import candidate_actions, candidates_json, load_candidates
from gfc.sim.execute import execute_plan
from gfc.sim.render import KeyFrames, render, save_png
from gfc.sim.report import print_outcome
from gfc.sim.world import build_world
from gfc.tasks import TASKS, sample_task

sim_app = typer.Typer(
    help=(
        "Run tasks and plans in the PyBullet simulator: two Franka Pandas at a table, objects "
        "built from primitives, skills executed under physics with OMPL motion planning.\n\n"
        "Every step reports success or a failure type: 1 = no IK solution or the skill's "
        "precondition does not hold, 2 = no collision-free path, 3 = physics (dropped, slipped, "
        "knocked over, spilled, missed)."
    ),
    no_args_is_help=True,
)
console = Console()

DEMO_HELP = (
    "Run a benchmark task's hand-written reference parameters on one sampled scene.\n\n"
    "Samples TASK's scene for SEED, executes the reference actions under physics, prints the "
    "per-step outcome (success or failure type 1/2/3 with the reason) and the goal check, and "
    "writes a key frame per stage (frame_NN.png) plus strip.png into OUT.\n\n"
    "Exits 0 only when every step succeeded and the task's goal holds in the simulator "
    "afterwards.\n\n"
    "Example: gfc sim demo hammer_nail --seed 3 --out frames/"
)
RENDER_HELP = "Draw a plan's initial scene to a PNG, headless (ER_TINY_RENDERER), after it settles."
BENCH_HELP = (
    "Time the simulator and write a Markdown table.\n\n"
    "Measures physics steps per second, scene building, RRTConnect around an obstacle, and the "
    "wall time of every skill and every full plan, running each task's reference parameters on "
    "SCENES sampled scenes.\n\n"
    "Example: gfc sim bench --scenes 10 --out docs/bench/sim.md"
)
VERIFY_HELP = (
    "Execute a plan's candidates in the simulator and print a per-step table.\n\n"
    "Candidates run best rank first, each in a freshly built scene. Each step reports success "
    "or failure type 1 (no IK solution / precondition not met), 2 (no collision-free path) or 3 "
    "(physics: dropped, slipped, missed, spilled), with the reason; then the plan's goal is "
    "checked in the simulator.\n\n"
    "Exits 0 when at least one candidate succeeds (every step and the goal), 1 when none does, "
    "2 when the inputs are invalid.\n\n"
    "Example: gfc sim demo pot_reorientation --candidates run/ && "
    "gfc verify run/plan.json run/candidates.json"
)


@sim_app.command("tasks")
def list_tasks() -> None:
    """List the benchmark tasks that `gfc sim demo` can run."""
    for name, sampler in sorted(TASKS.items()):
        doc = sys.modules[sampler.__module__].__doc__ or ""
        console.print(f"[bold]{name}[/]: {' '.join(doc.split())}")


@sim_app.command("demo", help=DEMO_HELP)
def demo(
    task: Annotated[str, typer.Argument(help=f"Task name: {', '.join(sorted(TASKS))}.")],
    seed: Annotated[int, typer.Option(help="Scene seed: object poses are sampled from it.")] = 0,
    out: Annotated[
        Path | None, typer.Option(help="Folder for key frames (PNG per stage + strip.png).")
    ] = None,
    candidates: Annotated[
        Path | None,
        typer.Option(help="Also write the plan and reference actions here (plan.json, candidates.json)."),
    ] = None,
) -> None:
    try:
        instance = sample_task(task, seed)
    except KeyError as exc:
        raise typer.BadParameter(str(exc.args[0]), param_hint="TASK") from None
    if candidates is not None:
        candidates.mkdir(parents=True, exist_ok=True)
        (candidates / "plan.json").write_text(json.dumps(instance.plan.to_json_dict(), indent=2))
        payload = {"candidates": [candidates_json(instance.reference_actions, instance.plan)]}
        (candidates / "candidates.json").write_text(json.dumps(payload, indent=2))
    frames = KeyFrames() if out is not None else None
    outcome = execute_plan(
        instance.plan,
        instance.reference_actions,
        seed=seed,
        contents=instance.contents,
        on_stage=None if frames is None else frames.record,
    )
    print_outcome(console, outcome, f"{task}, seed {seed}, reference parameters")
    if frames is not None and out is not None:
        paths = frames.save(out)
        console.print(f"  key frames: {len(paths) - 1} PNGs and {out / 'strip.png'}")
    raise typer.Exit(0 if outcome.success else 1)


@sim_app.command("render", help=RENDER_HELP)
def render_scene(
    plan: Annotated[Path, typer.Argument(help="Plan JSON whose scene to draw.")],
    out: Annotated[Path, typer.Option(help="PNG to write.")] = Path("scene.png"),
) -> None:
    request = _load(plan)
    with build_world(request.scene) as world:
        save_png(render(world), out)
    console.print(f"wrote {out}")


@sim_app.command("bench", help=BENCH_HELP)
def bench(
    scenes: Annotated[int, typer.Option(help="Sampled scenes per task.")] = 10,
    out: Annotated[
        Path | None, typer.Option(help="Write the Markdown table here (e.g. docs/bench/sim.md).")
    ] = None,
) -> None:
    from gfc.sim.bench import run_benchmark, to_markdown

    command = f"gfc sim bench --scenes {scenes}" + (f" --out {out}" if out else "")
    text = to_markdown(run_benchmark(scenes), command)
    console.print(text)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)


def _load(plan: Path) -> PlanRequest:
    try:
        return load_plan(plan)
    except PlanError as exc:
        console.print(f"[red]{exc}[/]")
        raise typer.Exit(2) from None


def verify(
    plan: Annotated[Path, typer.Argument(help="Plan JSON (the request the candidates answer).")],
    candidates: Annotated[
        Path,
        typer.Argument(
            help='Candidates JSON: {"candidates": [{"rank": 0, "steps": [{"step": 0, "skill": "pick", '
            '"action": [9 floats]}, ...]}]}; strike and pour take "action": [].'
        ),
    ],
    seed: Annotated[int, typer.Option(help="Seed for IK restarts and motion planning.")] = 0,
    top: Annotated[int, typer.Option(help="Execute at most this many candidates, best rank first.")] = 5,
    frames: Annotated[
        Path | None, typer.Option(help="Write key frames per candidate into this folder.")
    ] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write all outcomes as JSON here.")] = None,
    url: Annotated[
        str | None,
        typer.Option(envvar="GFC_URL", help="Verify as a job on this service (gfc serve) instead of here."),
    ] = None,
    wait: Annotated[
        bool, typer.Option("--wait/--no-wait", help="With --url: wait for the job's result.")
    ] = True,
) -> None:
    if url is not None:
        from gfc.cli.remote import verify_remote

        raise typer.Exit(verify_remote(plan, candidates, url, wait, seed=seed, top_k=top))
    request = _load(plan)
    try:
        ranked = sorted(load_candidates(candidates).candidates, key=lambda c: c.rank)[:top]
        actions = [candidate_actions(request, c) for c in ranked]
    except (ValueError, OSError) as exc:
        console.print(f"[red]{candidates}: {exc}[/]")
        raise typer.Exit(2) from None
    results = []
    any_success = False
    for candidate, values in zip(ranked, actions, strict=True):
        recorder = KeyFrames() if frames is not None else None
        outcome = execute_plan(
            request, values, seed=seed, on_stage=None if recorder is None else recorder.record
        )
        print_outcome(console, outcome, f"candidate rank {candidate.rank}")
        if recorder is not None and frames is not None:
            recorder.save(frames / f"rank_{candidate.rank}")
        any_success = any_success or outcome.success
        results.append({"rank": candidate.rank, **outcome.to_json()})
    if json_out is not None:
        json_out.write_text(json.dumps({"results": results}, indent=2))
    raise typer.Exit(0 if any_success else 1)


def register_sim_commands(app: typer.Typer) -> None:
    """Top-level commands that belong to the simulator (``gfc verify``)."""
    app.command("verify", help=VERIFY_HELP)(verify)
