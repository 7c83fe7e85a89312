"""Denoising score matching for one skill model, with random token dropping and EMA.

Split as STYLE.md asks: statistics, masks, one optimisation step, the loop, sampling. The skill
learning pipeline (data collection, the store, plots) builds on these.

Token dropping: a share of every batch keeps only a random non-empty subset of the tokens
(the others are masked out of attention and out of the loss). The model then also learns the
*marginals* of its tokens, which the planner needs for the paper's compensation term
(docs/adr/0001-composition.md).
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass, field

import torch

from gfc.diffusion.denoiser import StackedDenoiser, TokenLayout
from gfc.diffusion.edm import karras_sigmas, sample_training_sigmas
from gfc.diffusion.samplers import SAMPLERS

MIN_STD = 1e-3  # floor for a dimension's spread (constant dimensions, e.g. a table height)


@dataclass(frozen=True)
class TrainConfig:
    steps: int = 3000  # optimiser steps
    batch_size: int = 256
    lr: float = 3e-4  # AdamW
    weight_decay: float = 1e-4
    ema_decay: float = 0.999
    marginal_share: float = 0.25  # share of rows that keep a random subset of tokens
    clean_share: float = 0.3  # share of rows where some tokens are given clean (conditioning)
    grad_clip: float = 1.0
    p_mean: float = -1.2  # log-normal training noise (EDM)
    p_std: float = 1.2
    seed: int = 0


@dataclass
class TrainResult:
    model: StackedDenoiser  # the EMA weights, in eval mode
    losses: list[float] = field(default_factory=list)  # training loss per step
    val_losses: list[tuple[int, float]] = field(default_factory=list)  # (step, held-out loss)


def data_statistics(data: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-dimension mean and spread of flat data (N, D), spread floored at MIN_STD (also for a
    single row, whose sample spread is undefined)."""
    spread = data.std(0) if data.shape[0] > 1 else torch.zeros(data.shape[1])
    return data.mean(0), spread.clamp_min(MIN_STD)


def random_token_mask(batch: int, n_tokens: int, share: float, generator: torch.Generator) -> torch.Tensor:
    """(B, T) bool: most rows keep every token; ``share`` of them a random non-empty subset."""
    mask = torch.ones(batch, n_tokens, dtype=torch.bool)
    dropped = torch.rand(batch, generator=generator) < share
    n = int(dropped.sum())
    if n and n_tokens > 1:
        subset = torch.rand(n, n_tokens, generator=generator) < 0.5
        empty = ~subset.any(dim=1)
        keep_one = torch.randint(n_tokens, (n,), generator=generator)
        subset[empty, keep_one[empty]] = True
        mask[dropped] = subset
    return mask


def random_clean_mask(present: torch.Tensor, share: float, generator: torch.Generator) -> torch.Tensor:
    """(B, T) bool: in ``share`` of the rows, a random subset of the present tokens is given
    clean (as conditioning), always leaving at least one present token noisy."""
    b, t = present.shape
    chosen = (torch.rand(b, generator=generator) < share).unsqueeze(1)
    clean = chosen & present & (torch.rand(b, t, generator=generator) < 0.5)
    all_clean = (clean == present).all(dim=1) & present.any(dim=1)
    if bool(all_clean.any()):  # un-clean one present token in those rows
        scores = torch.rand(b, t, generator=generator) * present
        keep_noisy = scores.argmax(dim=1)
        clean[all_clean, keep_noisy[all_clean]] = False
    return clean


def dsm_loss(
    model: StackedDenoiser,
    data: torch.Tensor,
    present: torch.Tensor,
    generator: torch.Generator,
    p_mean: float = -1.2,
    p_std: float = 1.2,
    clean: torch.Tensor | None = None,
) -> torch.Tensor:
    """EDM-weighted denoising loss of a one-model stack on flat data.

    data: (B, D) flat tokens in the model's frame; present: (B, T) bool; clean: (B, T) bool
    tokens given without noise (conditioning; no loss on them).
    """
    layout = model.layouts[0]
    d_max = model.max_dim
    b = data.shape[0]
    sigma = sample_training_sigmas(b, generator, p_mean, p_std).to(data.dtype)  # (B,)
    x0 = layout.pad(data, d_max).unsqueeze(0)  # (1, B, T, D)
    noise = torch.randn(x0.shape, generator=generator, dtype=x0.dtype)
    if clean is not None:
        noise = noise * (~clean).unsqueeze(0).unsqueeze(-1)
    noisy = x0 + sigma.view(1, b, 1, 1) * noise
    denoised = model.denoise(
        noisy, sigma.view(1, b), present.unsqueeze(0), clean=None if clean is None else clean.unsqueeze(0)
    )
    std = model.std[:, : layout.n_tokens].unsqueeze(1)  # (1, 1, T, D)
    weight = (sigma.view(1, b, 1, 1) ** 2 + std**2) / (sigma.view(1, b, 1, 1) * std) ** 2
    dims = layout.dim_mask(d_max).unsqueeze(0).unsqueeze(0)  # (1, 1, T, D)
    scored = present if clean is None else present & ~clean
    mask = (dims & scored.unsqueeze(0).unsqueeze(-1)).to(data.dtype)  # (1, B, T, D)
    per_dim = weight * (denoised - x0) ** 2 * mask
    return per_dim.sum() / mask.sum().clamp_min(1.0)


def ema_decay_at(step: int, decay: float) -> float:
    """EMA decay with warm-up: short runs still average over their own steps rather than keep the
    initial weights (decay ``min(decay, (1 + step) / (10 + step))``)."""
    return min(decay, (1 + step) / (10 + step))


def _ema_update(ema: StackedDenoiser, model: StackedDenoiser, decay: float) -> None:
    with torch.no_grad():
        for e, p in zip(ema.parameters(), model.parameters(), strict=True):
            e.lerp_(p, 1.0 - decay)


def train_denoiser(
    model: StackedDenoiser,
    data: torch.Tensor,
    config: TrainConfig,
    val_data: torch.Tensor | None = None,
    on_step: Callable[[int, float], None] | None = None,
    val_every: int = 100,
) -> TrainResult:
    """Fit a one-model stack to flat data (N, D). The model's statistics must already be set."""
    if len(model.layouts) != 1:
        raise ValueError("train one model at a time (a stack of one)")
    layout: TokenLayout = model.layouts[0]
    if data.shape[1] != layout.total_dim:
        raise ValueError(f"data has {data.shape[1]} dims, the layout {layout.total_dim}")
    if config.clean_share > 0 and not model.accepts_clean:
        raise ValueError("training with clean tokens needs a model built with DiTConfig(conditioning=True)")
    generator = torch.Generator().manual_seed(config.seed)
    torch.manual_seed(config.seed)  # dropout inside the network
    model.train()
    ema = copy.deepcopy(model).eval()
    optimiser = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    result = TrainResult(model=ema)
    for step in range(config.steps):
        rows = torch.randint(data.shape[0], (config.batch_size,), generator=generator)
        present = random_token_mask(config.batch_size, layout.n_tokens, config.marginal_share, generator)
        clean = random_clean_mask(present, config.clean_share, generator) if config.clean_share > 0 else None
        loss = dsm_loss(model, data[rows], present, generator, config.p_mean, config.p_std, clean)
        optimiser.zero_grad(set_to_none=True)
        loss.backward()  # type: ignore[no-untyped-call]
        torch.nn.utils.clip_grad_norm_(model.parameters(), config.grad_clip)
        optimiser.step()
        _ema_update(ema, model, ema_decay_at(step, config.ema_decay))
        result.losses.append(float(loss.detach()))
        if on_step is not None:
            on_step(step, result.losses[-1])
        if val_data is not None and (step + 1) % val_every == 0:
            result.val_losses.append((step + 1, evaluate_loss(ema, val_data, config.seed)))
    model.eval()
    return result


def evaluate_loss(model: StackedDenoiser, data: torch.Tensor, seed: int = 0, n_noise: int = 4) -> float:
    """Mean held-out loss with all tokens present, over a few noise draws (fixed seed)."""
    generator = torch.Generator().manual_seed(seed + 1)
    present = torch.ones(data.shape[0], model.layouts[0].n_tokens, dtype=torch.bool)
    with torch.no_grad():
        return sum(float(dsm_loss(model, data, present, generator)) for _ in range(n_noise)) / n_noise


def sample_model(
    model: StackedDenoiser,
    n: int,
    steps: int = 50,
    present: torch.Tensor | None = None,
    sampler: str = "heun",
    generator: torch.Generator | None = None,
    given: tuple[torch.Tensor, torch.Tensor] | None = None,
) -> torch.Tensor:
    """Draw n samples (flat, (n, D)) from one model; ``present`` (T,) samples a marginal;
    ``given`` = (clean tokens (T,) bool, flat values (D,)) samples a conditional."""
    layout = model.layouts[0]
    mask = torch.ones(layout.n_tokens, dtype=torch.bool) if present is None else present
    pres = mask.view(1, 1, -1).expand(1, n, -1)
    clean = None if given is None else given[0].view(1, 1, -1).expand(1, n, -1)
    flat_clean = (
        None if given is None else layout.unpad(layout.dim_mask(model.max_dim) & given[0].view(-1, 1))
    )
    std = float(model.std.max())
    sigmas = karras_sigmas(steps, sigma_max=max(3.0, 20 * std))
    x = torch.randn(n, layout.total_dim, generator=generator) * sigmas[0]
    if given is not None and flat_clean is not None:
        x = torch.where(flat_clean, given[1], x)

    def denoiser(x_flat: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
        out = model.denoise(
            layout.pad(x_flat, model.max_dim).unsqueeze(0), sigma.view(1, 1), pres, clean=clean
        )
        return layout.unpad(out[0])

    with torch.no_grad():
        return SAMPLERS[sampler](denoiser, x, sigmas, generator=generator)
