"""Build the default skill library from nothing: collect each model's data, train it, publish it.

One ``BuildBudget`` says how many simulated attempts each model gets and how long it trains; the
``full`` budget made the committed library (docs/skills.md has the command and its timing), the
``tiny`` budget runs the same pipeline in CI in a few minutes. Models whose version already sits
in the target store under the budget's alias are skipped, so an interrupted build resumes (and
each dataset resumes shard by shard).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gfc.data.runner import CollectPlan, collect_dataset
from gfc.diffusion.network import DiTConfig
from gfc.diffusion.training import TrainConfig
from gfc.pool import Pool
from gfc.skills.training import plot_losses, train_skill

# The skill models the benchmark tasks use (strike and pour are terminal: no learned model).
DEFAULT_MODELS: tuple[str, ...] = (
    "pick.cube",
    "pick.lid",
    "pick.hammer",
    "pick.nail",
    "pick.mug",
    "pick.cup",
    "pick.pot",
    "move.cube",
    "move.hammer",
    "move.nail",
    "move.mug",
    "move.cup",
    "move.pot",
    "place.cube.lid",
    "place.cube.box",
    "place.lid.box",
    "place.hammer.box",
    "regrasp.hammer",
    # The single-arm tasks (hook reach, rearrangement push, packing).
    "pick.block",
    "pick.hook",
    "pull.hook.block",
    "push.hook.block",
    "place.hook.rack",
    "place.block.rack",
    "place.block.box",
)


@dataclass(frozen=True)
class BuildBudget:
    attempts: int  # simulated attempts per model
    train_steps: int
    batch_size: int = 128
    shard_size: int = 100
    extra_attempts: dict[str, int] = field(default_factory=dict)  # per model, where data is scarce


BUDGETS: dict[str, BuildBudget] = {
    "full": BuildBudget(attempts=150, train_steps=1000),
    "tiny": BuildBudget(attempts=4, train_steps=20, batch_size=16, shard_size=4),
}


@dataclass
class ModelBuild:
    model: str
    version: int
    rows: int
    data_success_rate: float
    collect_s: float
    train_s: float
    held_out_loss: float

    def to_json(self) -> dict[str, Any]:
        return dict(self.__dict__)


Progress = Callable[[str, str], None]  # (model, what is happening)


def build_model(
    model: str,
    budget: BuildBudget,
    data_root: Path,
    store: Any,
    pool: Pool,
    seed: int = 0,
    on_progress: Progress | None = None,
) -> ModelBuild:
    """Collect, train and publish one model (as bfloat16 weights: half the bytes, same samples
    within the sampler's noise; the store records the dtype)."""
    say = on_progress or (lambda _m, _w: None)
    began = time.perf_counter()
    attempts = budget.extra_attempts.get(model, budget.attempts)
    say(model, f"collecting {attempts} attempts")
    index = collect_dataset(
        CollectPlan(model, attempts, budget.shard_size, seed), data_root / model, pool,
        lambda shard, s: say(model, f"shard {shard}: {s.rows} rows, {s.success_rate:.0%} success"),
    )  # fmt: skip
    collected = time.perf_counter()
    if index.rows < 2:
        raise RuntimeError(
            f"{model}: only {index.rows} successful rows from {attempts} attempts; cannot train"
        )
    say(model, f"training on {index.rows} rows")
    config = TrainConfig(steps=budget.train_steps, batch_size=budget.batch_size, seed=seed)
    trained = train_skill(data_root / model, config, DiTConfig())
    plot_losses(trained.result, f"{model}: {index.rows} rows", data_root / model / "loss.png")
    tried = sum(s.attempts - s.failures.get("setup", 0) for s in index.shards)
    failed = sum(v for s in index.shards for k, v in s.failures.items() if k != "setup")
    data_rate = (tried - failed) / tried if tried else 0.0
    metadata = trained.metadata()
    metadata["metrics"] = {**trained.metrics, "data_success_rate": data_rate}
    metadata["command"] = f"gfc library build --only {model}"
    version = store.publish(model, trained.model.with_precision("bfloat16"), metadata, aliases=("latest",))
    return ModelBuild(
        model, version, index.rows, data_rate, collected - began, time.perf_counter() - collected,
        trained.metrics["held_out_loss"],
    )  # fmt: skip
