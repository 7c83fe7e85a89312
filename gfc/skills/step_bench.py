"""Micro-benchmark: stacked optimiser steps over the default library's models against one
single-model step per model, at the library build's batch size.

    python -m gfc.skills.step_bench                  # 25 models, batch 128
    python -m gfc.skills.step_bench --models 5 --steps 5 --threads 1

Three ways to take one optimiser step for every model, each with the real training loop on
random data in each model's real token layout (``gfc.data.runner.model_layout``):

- sequential: ``train_denoiser`` on each model alone (the build before stacking);
- one stack: ``train_stacked`` on all models at once, every row padded to the most tokens;
- stacks by token count: one ``train_stacked`` step per token count (what ``train_skills`` does).

The time per step is measured between step callbacks after a few warm-up steps, so model
building and optimiser set-up are left out.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import torch

from gfc.data.runner import model_layout
from gfc.diffusion.denoiser import TokenLayout, single_model
from gfc.diffusion.multi_training import build_stack, train_stacked
from gfc.diffusion.network import DiTConfig
from gfc.diffusion.training import TrainConfig, data_statistics, train_denoiser
from gfc.skills.build import DEFAULT_MODELS

OnStep = Callable[[int, Any], None]


@dataclass(frozen=True)
class StepTiming:
    n_models: int
    batch_size: int
    threads: int
    sequential_s: float  # one step of each model alone, summed over the models
    stacked_s: float  # one step of one stack of all models
    by_tokens_s: float  # one step of each stack of the models with one token count, summed

    def summary(self) -> str:
        return (
            f"{self.n_models} models, batch {self.batch_size}, {self.threads} torch threads; "
            f"one optimiser step for every model: sequential {self.sequential_s * 1e3:.0f} ms "
            f"({self.sequential_s / self.n_models * 1e3:.1f} ms per model), "
            f"one stack {self.stacked_s * 1e3:.0f} ms ({self.sequential_s / self.stacked_s:.2f}x), "
            f"stacks by token count {self.by_tokens_s * 1e3:.0f} ms ({self.sequential_s / self.by_tokens_s:.2f}x)"
        )


def _seconds_per_step(fit: Callable[[OnStep], object], warmup: int) -> float:
    """Mean interval between step callbacks of ``fit(on_step)``, after ``warmup`` steps."""
    stamps: list[float] = []

    def on_step(step: int, _loss: Any) -> None:
        if step >= warmup - 1:
            stamps.append(time.perf_counter())

    fit(on_step)
    return (stamps[-1] - stamps[0]) / (len(stamps) - 1)


def _stacked_step(
    layouts: list[TokenLayout], data: list[torch.Tensor], config: TrainConfig, warmup: int
) -> float:
    stack = build_stack(layouts, data, DiTConfig(conditioning=True))
    return _seconds_per_step(lambda on_step: train_stacked(stack, data, config, on_step=on_step), warmup)


def time_steps(
    layouts: list[TokenLayout], batch_size: int = 128, steps: int = 8, warmup: int = 2, rows: int = 150
) -> StepTiming:
    """Seconds per optimiser step for all models, three ways (``steps`` timed steps after
    ``warmup`` untimed ones, each)."""
    network = DiTConfig(conditioning=True)  # as the library build trains them
    config = TrainConfig(steps=warmup + steps, batch_size=batch_size)
    generator = torch.Generator().manual_seed(0)
    data = [torch.randn(rows, layout.total_dim, generator=generator) for layout in layouts]
    sequential = 0.0
    for layout, flat in zip(layouts, data, strict=True):
        model = single_model(layout, network, *data_statistics(flat))
        sequential += _seconds_per_step(
            lambda on_step: train_denoiser(model, flat, config, on_step=on_step),  # noqa: B023
            warmup,
        )
    stacked = _stacked_step(layouts, data, config, warmup)
    by_tokens = 0.0
    for n in sorted({layout.n_tokens for layout in layouts}):
        group = [i for i, layout in enumerate(layouts) if layout.n_tokens == n]
        by_tokens += _stacked_step([layouts[i] for i in group], [data[i] for i in group], config, warmup)
    return StepTiming(len(layouts), batch_size, torch.get_num_threads(), sequential, stacked, by_tokens)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", type=int, default=len(DEFAULT_MODELS), help="the first N default models")
    parser.add_argument("--batch-size", type=int, default=128)
    parser.add_argument("--steps", type=int, default=8, help="timed steps (after 2 warm-up steps)")
    parser.add_argument("--threads", type=int, default=0, help="torch threads (default: torch's choice)")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    layouts = [model_layout(m) for m in DEFAULT_MODELS[: args.models]]
    print(time_steps(layouts, args.batch_size, args.steps).summary())


if __name__ == "__main__":
    main()
