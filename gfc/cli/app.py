"""Top-level ``gfc`` application: wires the command families together."""

from __future__ import annotations

import typer

from gfc.cli.bench import bench_app
from gfc.cli.collect import register_collect_command
from gfc.cli.library import library_app
from gfc.cli.plan_commands import register_plan_commands
from gfc.cli.remote import register_remote_commands
from gfc.cli.serve import register_serve_command
from gfc.cli.train import register_train_command
from gfc.sim.cli import register_sim_commands, sim_app
from skill_store.cli import skills_app

app = typer.Typer(
    name="gfc",
    help=(
        "Generative Factor Chaining: plan coordinated two-arm manipulation by composing "
        "per-skill diffusion models over a spatial-temporal factor graph.\n\n"
        "A plan is JSON: a scene (robots, objects), a skeleton of skills, spatial constraints "
        "and a goal. Start with:\n\n"
        "  gfc validate gfc/examples/hammer_place.json   # check a plan, see its factor graph\n\n"
        "  gfc bench latency                         # how fast the composed sampler is\n\n"
        "  gfc sim demo hammer_place --out frames/   # run a task in the simulator"
    ),
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
register_plan_commands(app)
register_remote_commands(app)
register_serve_command(app)
register_collect_command(app)
register_train_command(app)
register_sim_commands(app)
app.add_typer(sim_app, name="sim")
app.add_typer(bench_app, name="bench")
app.add_typer(skills_app, name="skills")
app.add_typer(library_app, name="library")


def main() -> None:
    app()
