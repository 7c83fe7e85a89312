"""``gfc collect``: a skill's dataset from the simulator."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer


def register_collect_command(app: typer.Typer) -> None:
    @app.command()
    def collect(
        skill: Annotated[str, typer.Argument(help="skill (pick, place, move, regrasp) or a model key (place.hammer.box)")],
        kind: Annotated[str | None, typer.Option("--object", help="object kind, e.g. cube, hammer; 'empty' for an empty-handed move")] = None,
        target: Annotated[str | None, typer.Option(help="target kind for skills with a target (place: box, lid)")] = None,
        n: Annotated[int, typer.Option("-n", min=1, help="executions to attempt (successes become rows)")] = 1000,
        out: Annotated[Path | None, typer.Option(help="dataset directory (default data/MODEL)")] = None,
        shard_size: Annotated[int, typer.Option(min=1, help="executions per shard")] = 100,
        processes: Annotated[int, typer.Option(min=1, help="simulator processes")] = 2,
        uniform_share: Annotated[float, typer.Option(min=0.0, max=1.0, help="share of uniformly random actions")] = 0.1,
        seed: Annotated[int, typer.Option(min=0)] = 0,
    ) -> None:  # fmt: skip
        """Execute a skill on random scenes with actions from a broad prior; keep the successes.

        Each attempt samples a scene in which the skill can be tried, runs its set-up (a place
        needs the object in hand first: a heuristic pick), draws the skill's action from a
        heuristic proposal with noise (or, for --uniform-share of the attempts, uniformly), runs
        it in a fresh simulated world, and keeps (pre nodes, action, effect nodes) in the acting
        robot's frame when it succeeds. Failed set-ups are counted apart. Shards are written
        atomically: run the same command again to resume after an interruption. Prints the
        success rate per shard.

        Examples:
          gfc collect pick --object hammer -n 400
          gfc collect place --object hammer --target box -n 400
          gfc train place.hammer.box --data data/place.hammer.box
        """
        from rich.console import Console
        from rich.progress import Progress
        from rich.table import Table

        from gfc.data.collect import Prior
        from gfc.data.dataset import Shard
        from gfc.data.runner import CollectPlan, collect_dataset
        from gfc.data.scenarios import SCENARIOS
        from gfc.pool import LocalPool
        from gfc.skills.signatures import default_model_key

        console = Console()
        model = skill if "." in skill else default_model_key(skill, kind, target)
        if model not in SCENARIOS:
            console.print(
                f"[red]error[/]: no scene sampler for skill model {model!r}; have: {', '.join(sorted(SCENARIOS))}"
            )
            raise typer.Exit(2)
        plan = CollectPlan(model, n, shard_size, seed, Prior(uniform_share))
        table = Table(title=f"{model}: success rate per shard")
        for col in ("shard", "attempts", "rows", "success", "failures by type"):
            table.add_column(col)
        shards = (n + shard_size - 1) // shard_size
        with Progress(console=console) as progress:
            task = progress.add_task(f"collecting {model}", total=shards)

            def done(shard: int, written: Shard) -> None:
                table.add_row(
                    str(shard), str(written.attempts), str(written.rows), f"{written.success_rate:.0%}",
                    str(written.failures),
                )  # fmt: skip
                progress.update(task, advance=1)

            with LocalPool(processes, keep_alive=True) as pool:
                index = collect_dataset(plan, out or Path("data") / model, pool, done)
        console.print(table)
        console.print(
            f"{index.rows} rows in {out or Path('data') / model} (content hash {index.content_hash[:12]})"
        )
