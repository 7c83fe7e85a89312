"""Train skill models from their datasets: split, statistics, DiT, denoising score matching.

Split into load, build, fit, evaluate, plot (STYLE.md); ``gfc train`` strings them together for
one model and publishes the result to the skill store. ``train_skills`` trains many models at
once as stacks (``gfc.diffusion.multi_training``), each model getting the split, statistics,
batches and metrics that ``train_skill`` would give it; ``gfc library build`` uses it.
"""

from __future__ import annotations

import shlex
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import torch

from gfc.data.dataset import DatasetIndex, load_dataset
from gfc.diffusion.denoiser import StackedDenoiser, single_model
from gfc.diffusion.multi_training import build_stack, train_stacked
from gfc.diffusion.network import DiTConfig
from gfc.diffusion.training import TrainConfig, TrainResult, data_statistics, evaluate_loss, train_denoiser

GroupStep = Callable[[Sequence[str], int, list[float]], None]  # (models trained together, step, losses)


@dataclass
class TrainedSkill:
    name: str
    model: StackedDenoiser
    result: TrainResult
    index: DatasetIndex
    metrics: dict[str, float]
    seed: int

    def metadata(self) -> dict[str, Any]:
        """The training record for the skill store's manifest."""
        return {
            "data_hash": self.index.content_hash,
            "metrics": self.metrics,
            "seed": self.seed,
            "command": shlex.join(["gfc", *sys.argv[1:]]) if sys.argv else "gfc train",
        }


def split(data: torch.Tensor, held_out: float, seed: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Shuffle and split rows into (train, held-out); at least one row in each."""
    if data.shape[0] < 2:
        raise ValueError(f"need at least 2 rows to split, got {data.shape[0]}")
    order = torch.randperm(data.shape[0], generator=torch.Generator().manual_seed(seed))
    n_val = min(max(1, round(held_out * data.shape[0])), data.shape[0] - 1)
    return data[order[n_val:]], data[order[:n_val]]


def train_skill(
    dataset_dir: str | Path,
    config: TrainConfig,
    network: DiTConfig | None = None,
    held_out: float = 0.1,
    on_step: Callable[[int, float], None] | None = None,
) -> TrainedSkill:
    data, index = load_dataset(dataset_dir)
    train, val = split(data, held_out, config.seed)
    mean, std = data_statistics(train)
    model = single_model(index.layout, _network(network, config), mean, std)
    result = train_denoiser(
        model, train, config, val_data=val, on_step=on_step, val_every=max(1, config.steps // 20)
    )
    metrics = _metrics(result, train, val, config.seed)
    return TrainedSkill(index.skill, result.model, result, index, metrics, config.seed)


def train_skills(
    dataset_dirs: Sequence[str | Path],
    config: TrainConfig,
    network: DiTConfig | None = None,
    held_out: float = 0.1,
    on_step: GroupStep | None = None,
) -> list[TrainedSkill]:
    """Train several skill models at once, in dataset order; each as ``train_skill`` would.

    Models with the same number of tokens train as one stack (``train_stacked``): one optimiser
    step for all of them. Stacking models of different token counts would pad every row to the
    most tokens, and the step's cost grows with the tokens, so each token count gets its own
    stack. Each model is initialised from ``config.seed`` alone, and draws its batches as it would
    alone; only the dropout masks depend on which models share a stack.
    """
    loaded = [load_dataset(d) for d in dataset_dirs]
    splits = [split(data, held_out, config.seed) for data, _ in loaded]
    indexes = [index for _, index in loaded]
    config_net = _network(network, config)
    out: dict[int, TrainedSkill] = {}
    for group in _same_token_count(indexes):
        names = [indexes[i].skill for i in group]
        trains, vals = [splits[i][0] for i in group], [splits[i][1] for i in group]
        stack = build_stack([indexes[i].layout for i in group], trains, config_net, seed=config.seed)
        report = None if on_step is None else partial(on_step, names)
        stacked = train_stacked(
            stack, trains, config, val_data=vals, on_step=report, val_every=max(1, config.steps // 20)
        )
        for i, train, val, result in zip(group, trains, vals, stacked.results(), strict=True):
            metrics = _metrics(result, train, val, config.seed)
            out[i] = TrainedSkill(indexes[i].skill, result.model, result, indexes[i], metrics, config.seed)
    return [out[i] for i in range(len(loaded))]


def _network(network: DiTConfig | None, config: TrainConfig) -> DiTConfig:
    """Trained with clean (observed) tokens too, so the planner can condition on them exactly."""
    return replace(network or DiTConfig(), conditioning=config.clean_share > 0)


def _same_token_count(indexes: Sequence[DatasetIndex]) -> list[list[int]]:
    """Positions of the datasets grouped by their layout's token count (ascending)."""
    groups: dict[int, list[int]] = {}
    for i, index in enumerate(indexes):
        groups.setdefault(index.layout.n_tokens, []).append(i)
    return [groups[t] for t in sorted(groups)]


def _metrics(result: TrainResult, train: torch.Tensor, val: torch.Tensor, seed: int) -> dict[str, float]:
    return {
        "train_loss_final": sum(result.losses[-50:]) / len(result.losses[-50:]),
        "held_out_loss": evaluate_loss(result.model, val, seed),
        "rows_train": float(train.shape[0]),
        "rows_held_out": float(val.shape[0]),
    }


def plot_losses(result: TrainResult, title: str, path: str | Path) -> Path:
    """Training loss (raw and smoothed) and held-out loss against steps, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    losses = torch.tensor(result.losses)
    window = max(1, len(result.losses) // 50)
    smooth = torch.nn.functional.avg_pool1d(losses.view(1, 1, -1), window, stride=1).view(-1)
    fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
    ax.plot(range(len(losses)), losses.numpy(), color="#c8d6e5", linewidth=0.8, label="train (per step)")
    ax.plot(
        range(window - 1, window - 1 + len(smooth)), smooth.numpy(), color="#2e86de", label="train (smoothed)"
    )
    if result.val_losses:
        steps, vals = zip(*result.val_losses, strict=True)
        ax.plot(steps, vals, "o-", color="#ee5253", markersize=3, label="held-out (EMA weights)")
    ax.set_yscale("log")
    ax.set_xlabel("optimiser step")
    ax.set_ylabel("EDM-weighted denoising loss")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    plt.close(fig)
    return out
