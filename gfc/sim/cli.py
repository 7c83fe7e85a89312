"""``gfc sim ...`` and ``gfc verify``: run plans in the simulator."""

from __future__ import annotations

import typer

sim_app = typer.Typer(help="Run tasks and plans in the PyBullet simulator.", no_args_is_help=True)


def register_sim_commands(app: typer.Typer) -> None:
    """Top-level commands that belong to the simulator (``gfc verify``)."""
