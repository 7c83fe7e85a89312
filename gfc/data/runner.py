"""Collect one skill model's dataset: attempts in shards over the simulation pool, resumable."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from gfc.data.collect import Prior, attempts_for, run_attempt, summarise
from gfc.data.dataset import DatasetIndex, DatasetWriter, Shard
from gfc.data.scenarios import scenario_for
from gfc.diffusion.denoiser import TokenLayout
from gfc.pool import Pool
from gfc.skills.signatures import skill_spec

ShardDone = Callable[[int, Shard], None]


def model_layout(model: str) -> TokenLayout:
    """The token layout of a skill model from its key (``move.empty`` has no object token)."""
    skill, kind = model.split(".")[:2]
    tokens = skill_spec(skill).tokens(with_object=kind != "empty")
    return TokenLayout(tuple(t.dim for t in tokens), tuple(t.kind for t in tokens))


@dataclass(frozen=True)
class CollectPlan:
    model: str
    attempts: int
    shard_size: int = 100
    seed: int = 0
    prior: Prior = field(default_factory=Prior)


def collect_dataset(
    plan: CollectPlan, out: str | Path, pool: Pool, on_shard: ShardDone | None = None
) -> DatasetIndex:
    """Run the plan's attempts (the shards not already on disk) and return the dataset index.

    Attempt seeds depend only on (seed, attempt number), so an interrupted run resumed later
    yields the same rows as an uninterrupted one.
    """
    scenario_for(plan.model)  # fail early on a model without a scene sampler
    layout = model_layout(plan.model)
    command = f"gfc collect {plan.model} -n {plan.attempts} --seed {plan.seed}"
    writer = DatasetWriter(out, plan.model, layout, {"command": command, "seed": plan.seed})
    shards = (plan.attempts + plan.shard_size - 1) // plan.shard_size
    for shard in range(writer.next_shard, shards):
        first = plan.seed * 1_000_003 + shard * plan.shard_size
        count = min(plan.shard_size, plan.attempts - shard * plan.shard_size)
        results = pool.map(
            run_attempt, attempts_for(plan.model, range(first, first + count), prior=plan.prior)
        )
        summary = summarise(results, layout.total_dim)
        written = writer.add_shard(summary.rows, len(results), summary.failures)
        if on_shard is not None:
            on_shard(shard, written)
    return writer.index
