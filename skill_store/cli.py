"""``gfc skills ...``: list, show, push, pull, verify and alias skill versions."""

from __future__ import annotations

import typer

skills_app = typer.Typer(help="Manage the skill store: versioned skill model checkpoints.", no_args_is_help=True)
