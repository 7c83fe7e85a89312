"""``gfc train``: fit one skill model to its dataset and publish it to the skill store."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer


def register_train_command(app: typer.Typer) -> None:
    @app.command()
    def train(
        skill: Annotated[str, typer.Argument(help="skill model name, e.g. pick.hammer")],
        data: Annotated[Path, typer.Option(help="dataset directory (from gfc collect)")],
        steps: Annotated[int, typer.Option(min=1, help="optimiser steps")] = 3000,
        batch_size: Annotated[int, typer.Option(min=1)] = 256,
        lr: Annotated[float, typer.Option(min=0.0)] = 3e-4,
        seed: Annotated[int, typer.Option(min=0)] = 0,
        hidden: Annotated[int, typer.Option(min=8, help="DiT width (the paper: 128)")] = 128,
        depth: Annotated[int, typer.Option(min=1, help="DiT blocks (the paper: 2)")] = 2,
        store: Annotated[
            str | None,
            typer.Option(help="skill store path or URL (env GFC_SKILL_STORE; default: packaged library)"),
        ] = None,
        alias: Annotated[
            list[str] | None, typer.Option(help="aliases to move to the new version (repeat)")
        ] = None,
        plot: Annotated[Path | None, typer.Option(help="loss curve PNG (default: DATA/loss.png)")] = None,
    ) -> None:
        """Train SKILL on its dataset with denoising score matching and publish it.

        Holds out 10% of the rows, trains the paper's DiT (hidden 128, 2 blocks, 2 heads, MLP
        ratio 2) with random token dropping (so the model also knows its nodes' marginals) and
        an EMA of the weights, writes the loss curve, and publishes the EMA model as the next
        version in the skill store with its data hash, metrics, seed and this command.

        Example: gfc train pick.hammer --data data/pick.hammer --steps 3000 --alias latest
        """
        import os

        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

        from gfc.data.dataset import DatasetError, read_index
        from gfc.diffusion.network import DiTConfig
        from gfc.diffusion.training import TrainConfig
        from gfc.skills.training import plot_losses, train_skill
        from skill_store import DEFAULT_LIBRARY, SkillStore

        console = Console()
        try:
            index = read_index(data)
        except DatasetError as exc:
            console.print(f"[red]error[/]: {exc}")
            raise typer.Exit(2) from None
        if index.skill != skill:
            console.print(f"[red]error[/]: {data} holds data for {index.skill!r}, not {skill!r}")
            raise typer.Exit(2)
        config = TrainConfig(steps=steps, batch_size=batch_size, lr=lr, seed=seed)
        network = DiTConfig(hidden=hidden, depth=depth)
        columns = [TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                   TextColumn("loss {task.fields[loss]:.3f}"), TimeRemainingColumn()]  # fmt: skip
        with Progress(*columns, console=console) as progress:
            task = progress.add_task(f"training {skill}", total=steps, loss=float("nan"))
            trained = train_skill(
                data, config, network, on_step=lambda _, loss: progress.update(task, advance=1, loss=loss)
            )
        curve = plot_losses(trained.result, f"{skill}: {index.rows} rows", plot or data / "loss.png")
        target = SkillStore(store or os.environ.get("GFC_SKILL_STORE") or DEFAULT_LIBRARY)
        version = target.publish(skill, trained.model, trained.metadata(), aliases=tuple(alias or ()))
        console.print(
            f"published [bold]{skill}@{version}[/] to {target.location}: held-out loss "
            f"{trained.metrics['held_out_loss']:.4f}, loss curve {curve}"
        )
