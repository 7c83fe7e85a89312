"""``gfc collect``: a skill's dataset from the simulator."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer


def register_collect_command(app: typer.Typer) -> None:
    @app.command()
    def collect(
        skill: Annotated[str, typer.Argument(help="skill to collect (so far: pick)")],
        kind: Annotated[str, typer.Option("--object", help="object kind, e.g. cube, hammer")],
        n: Annotated[
            int, typer.Option("-n", min=1, help="executions to attempt (successes become rows)")
        ] = 1000,
        out: Annotated[Path | None, typer.Option(help="dataset directory (default data/SKILL.KIND)")] = None,
        shard_size: Annotated[int, typer.Option(min=1, help="executions per shard")] = 200,
        processes: Annotated[int, typer.Option(min=1, help="simulator processes")] = 2,
        seed: Annotated[int, typer.Option(min=0)] = 0,
    ) -> None:
        """Execute SKILL on random scenes with actions from a broad prior; keep the successes.

        Each attempt samples a scene, perturbs a heuristic action (and draws 20% uniformly),
        runs it in a fresh simulated world, and keeps (pre nodes, action, effect nodes) in the
        acting robot's frame when it succeeds. Shards are written atomically: run the same
        command again to resume after an interruption. Prints the success rate per shard.

        Example: gfc collect pick --object cube -n 2000 && gfc train pick.cube --data data/pick.cube
        """
        from rich.console import Console
        from rich.progress import Progress
        from rich.table import Table

        from gfc.data.collect import SCENARIOS, Attempt, Prior, run_attempt, summarise
        from gfc.data.dataset import DatasetWriter
        from gfc.diffusion.denoiser import TokenLayout
        from gfc.kinds import OBJECT_KINDS
        from gfc.pool import LocalPool
        from gfc.skills.signatures import skill_spec

        console = Console()
        if skill not in SCENARIOS:
            console.print(
                f"[red]error[/]: no scene sampler for {skill!r} yet (have: {', '.join(sorted(SCENARIOS))})"
            )
            raise typer.Exit(2)
        if kind not in OBJECT_KINDS or not OBJECT_KINDS[kind].graspable:
            console.print(f"[red]error[/]: {kind!r} is not a graspable object kind")
            raise typer.Exit(2)
        name = f"{skill}.{kind}"
        tokens = skill_spec(skill).tokens()
        layout = TokenLayout(tuple(t.dim for t in tokens), tuple(t.kind for t in tokens))
        writer = DatasetWriter(
            out or Path("data") / name,
            name,
            layout,
            {"command": f"gfc collect {skill} --object {kind}", "seed": seed},
        )
        shards = (n + shard_size - 1) // shard_size
        pool = LocalPool(processes)
        table = Table(title=f"{name}: success rate per shard")
        for col in ("shard", "attempts", "rows", "success", "failures by type"):
            table.add_column(col)
        with Progress(console=console) as progress:
            task = progress.add_task(f"collecting {name}", total=shards, completed=writer.next_shard)
            for shard in range(writer.next_shard, shards):
                first = seed * 1_000_003 + shard * shard_size
                attempts = [
                    Attempt(skill, kind, first + i, Prior())
                    for i in range(min(shard_size, n - shard * shard_size))
                ]
                rows, count, failures = summarise(pool.map(run_attempt, attempts))
                written = writer.add_shard(rows.reshape(-1, layout.total_dim), count, failures)
                table.add_row(
                    str(shard), str(count), str(written.rows), f"{written.success_rate:.0%}", str(failures)
                )
                progress.update(task, advance=1)
        console.print(table)
        console.print(
            f"{writer.index.rows} rows in {writer.root} (content hash {writer.index.content_hash[:12]})"
        )
