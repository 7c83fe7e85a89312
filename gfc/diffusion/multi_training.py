"""Several skill models trained at once as one stack: one optimiser step updates all of them.

``DiTStack`` runs M models in one pass (bmm over the model dimension), so ``train_stacked``
trains M models, each on its own batch, with one forward and backward pass. What that saves is
measured by ``python -m gfc.skills.step_bench``: a one-model step on 128 rows is mostly matmul
work, not per-call overhead, so a stack costs nearly the sum of its models' work; it saves the
per-call share and gives both threads of a 2-core machine large matmuls to split. Rows are padded
to the stack's most tokens, and that padding costs as much as real tokens: stack models of one
token count together (``gfc.skills.training.train_skills`` does).

Each model keeps what it would have had alone: its own data, statistics, held-out rows and random
stream. Model m draws its rows, token masks, noise levels and noise from a generator seeded with
``config.seed``, in the order ``train_denoiser`` draws them, so its batches are the ones it would
get alone. The loss is the sum over models of each model's ``dsm_loss``; the models' parameters
are disjoint slices of the stacked tensors, so each slice receives its own model's gradient only.
AdamW and the EMA are element-wise, and gradients are clipped per model (``clip_grad_norm_per_model``,
the same rule as ``clip_grad_norm_`` on one model's parameters). With dropout 0 the stacked run
therefore reproduces the single runs up to float rounding (tests/diffusion/test_multi_training.py);
with dropout, the dropout masks are drawn for the whole stack and differ from a single run's.

Mixed layouts are padded as ``StackedDenoiser.concatenate`` pads them: a model with fewer tokens
gets absent padding tokens (out of attention and out of the loss).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import torch
import torch.nn.functional as F
from torch import nn

from gfc.diffusion.denoiser import StackedDenoiser, TokenLayout, single_model
from gfc.diffusion.edm import sample_training_sigmas
from gfc.diffusion.network import DiTConfig, DiTStack
from gfc.diffusion.training import (
    TrainConfig,
    TrainResult,
    _ema_update,
    data_statistics,
    ema_decay_at,
    random_clean_mask,
    random_token_mask,
)

StepCallback = Callable[[int, list[float]], None]  # (step, each model's loss)


@dataclass
class StackedTrainResult:
    model: StackedDenoiser  # the EMA weights of all M models, in eval mode
    losses: list[list[float]]  # per model: training loss per step
    val_losses: list[list[tuple[int, float]]]  # per model: (step, held-out loss)

    def results(self) -> list[TrainResult]:
        """One ``TrainResult`` per model, with the model split out of the stack."""
        singles = split_stack(self.model)
        return [
            TrainResult(model=single, losses=losses, val_losses=vals)
            for single, losses, vals in zip(singles, self.losses, self.val_losses, strict=True)
        ]


@dataclass(frozen=True)
class _Batch:
    """One batch per model, padded to the stack's T tokens (and, for held-out data, to the most
    rows; ``rows`` marks the real ones)."""

    x0: torch.Tensor  # (M, B, T, D) clean data
    noise: torch.Tensor  # (M, B, T, D) unit noise, zero on clean tokens
    sigma: torch.Tensor  # (M, B)
    present: torch.Tensor  # (M, B, T) bool
    clean: torch.Tensor | None  # (M, B, T) bool
    rows: torch.Tensor  # (M, B) bool


# -- building and splitting stacks ---------------------------------------------------------------


def build_stack(
    layouts: Sequence[TokenLayout], data: Sequence[torch.Tensor], config: DiTConfig, seed: int | None = None
) -> StackedDenoiser:
    """A fresh stack of ``len(layouts)`` models, each with the statistics of its own flat training
    data (N_m, D_m) (``data_statistics``), initialised as ``single_model`` initialises one.

    With ``seed``, each model's initial weights are drawn from that seed alone (whatever else is
    in the stack), without touching the global random state; without, from the global state."""
    if len(layouts) != len(data) or not layouts:
        raise ValueError(f"{len(layouts)} layouts for {len(data)} datasets")
    singles = []
    for layout, rows in zip(layouts, data, strict=True):
        with torch.random.fork_rng(devices=[], enabled=seed is not None):
            if seed is not None:
                torch.manual_seed(seed)
            singles.append(single_model(layout, config, *data_statistics(rows)))
    return StackedDenoiser.concatenate(singles)


def split_stack(stack: StackedDenoiser) -> list[StackedDenoiser]:
    """Each model of a stack as a stack of one, shaped exactly as ``single_model`` builds it (its
    own token count), so the skill store publishes and loads it as any single model."""
    return [select_model(stack, m) for m in range(len(stack.layouts))]


def select_model(stack: StackedDenoiser, m: int) -> StackedDenoiser:
    """Model ``m`` of a stack as a stack of one (copied weights, same dtype and mode)."""
    layout = stack.layouts[m]
    t = layout.n_tokens
    network = DiTStack(stack.config, n_models=1, n_tokens=t).to(stack.network.enc_w.dtype)
    with torch.no_grad():
        for name, param in network.named_parameters():
            source = stack.network.get_parameter(name)[m : m + 1]
            if name == "role_emb":
                source = source[:, :t]  # (1, T_m, H): the padding slots belong to no model
            param.copy_(source)
    mean = stack.mean[m : m + 1, :t].clone()  # (1, T_m, D_max)
    std = stack.std[m : m + 1, :t].clone()
    return StackedDenoiser(network, [layout], mean, std).train(stack.training)


# -- batches -------------------------------------------------------------------------------------


def _pad_tokens(x: torch.Tensor, n_tokens: int) -> torch.Tensor:
    """(B, T_m, ...) -> (B, T, ...), zeros (False) in the added tokens."""
    pad = n_tokens - x.shape[1]
    if pad == 0:
        return x
    if x.dim() == 2:
        return F.pad(x, (0, pad))
    return F.pad(x, (0, 0, 0, pad))


class _Draw(NamedTuple):
    """One model's batch before padding to the stack's tokens."""

    x0: torch.Tensor  # (B, T_m, D)
    noise: torch.Tensor  # (B, T_m, D)
    sigma: torch.Tensor  # (B,)
    present: torch.Tensor  # (B, T_m) bool
    clean: torch.Tensor | None  # (B, T_m) bool


def _draw_model_batch(
    data: torch.Tensor, layout: TokenLayout, config: TrainConfig, generator: torch.Generator
) -> _Draw:
    """One model's training batch from its padded rows (N, T_m, D), drawn in the order in which
    ``train_denoiser`` and ``dsm_loss`` draw it from the model's generator."""
    b = config.batch_size
    rows = torch.randint(data.shape[0], (b,), generator=generator)
    present = random_token_mask(b, layout.n_tokens, config.marginal_share, generator)
    clean = random_clean_mask(present, config.clean_share, generator) if config.clean_share > 0 else None
    sigma = sample_training_sigmas(b, generator, config.p_mean, config.p_std)
    x0 = data[rows]  # (B, T_m, D)
    noise = torch.randn(x0.shape, generator=generator)
    if clean is not None:
        noise = noise * (~clean).unsqueeze(-1)
    return _Draw(x0, noise, sigma, present, clean)


def _training_batch(
    data: Sequence[torch.Tensor],
    layouts: Sequence[TokenLayout],
    n_tokens: int,
    config: TrainConfig,
    generators: Sequence[torch.Generator],
) -> _Batch:
    parts = [
        _draw_model_batch(d, layout, config, g)
        for d, layout, g in zip(data, layouts, generators, strict=True)
    ]
    cleans = [p.clean for p in parts if p.clean is not None]
    return _Batch(
        x0=torch.stack([_pad_tokens(p.x0, n_tokens) for p in parts]),
        noise=torch.stack([_pad_tokens(p.noise, n_tokens) for p in parts]),
        sigma=torch.stack([p.sigma for p in parts]),
        present=torch.stack([_pad_tokens(p.present, n_tokens) for p in parts]),
        clean=torch.stack([_pad_tokens(c, n_tokens) for c in cleans]) if cleans else None,
        rows=torch.ones(len(parts), config.batch_size, dtype=torch.bool),
    )


def _held_out_batch(
    data: Sequence[torch.Tensor],
    layouts: Sequence[TokenLayout],
    n_tokens: int,
    generators: Sequence[torch.Generator],
) -> _Batch:
    """All held-out rows of every model with every token present and one noise draw each, drawn
    as ``evaluate_loss`` draws them; rows padded to the longest set."""
    n_rows = max(d.shape[0] for d in data)
    m, d_max = len(data), data[0].shape[-1]
    x0 = torch.zeros(m, n_rows, n_tokens, d_max)
    noise = torch.zeros(m, n_rows, n_tokens, d_max)
    sigma = torch.ones(m, n_rows)
    present = torch.zeros(m, n_rows, n_tokens, dtype=torch.bool)
    rows = torch.zeros(m, n_rows, dtype=torch.bool)
    for i, (d, layout, g) in enumerate(zip(data, layouts, generators, strict=True)):
        n, t = d.shape[0], layout.n_tokens
        sigma[i, :n] = sample_training_sigmas(n, g)  # evaluate_loss uses dsm_loss's default levels
        noise[i, :n, :t] = torch.randn(d.shape, generator=g)
        x0[i, :n, :t] = d
        present[i, :, :t] = True  # padding rows too: every row needs a token to attend to
        rows[i, :n] = True
    return _Batch(x0=x0, noise=noise, sigma=sigma, present=present, clean=None, rows=rows)


# -- loss, clipping, the loop ----------------------------------------------------------------------


def stacked_dsm_loss(model: StackedDenoiser, batch: _Batch, dims: torch.Tensor) -> torch.Tensor:
    """Each model's ``dsm_loss`` on its own batch, in one pass. dims: (M, 1, T, D) bool, the real
    dimensions of each model's tokens -> (M,) losses."""
    m, b = batch.sigma.shape
    sigma = batch.sigma.view(m, b, 1, 1)
    noisy = batch.x0 + sigma * batch.noise  # (M, B, T, D)
    denoised = model.denoise(noisy, batch.sigma, batch.present, clean=batch.clean)
    std = model.std.unsqueeze(1)  # (M, 1, T, D)
    weight = (sigma**2 + std**2) / (sigma * std) ** 2  # (M, B, T, D)
    scored = batch.present if batch.clean is None else batch.present & ~batch.clean  # (M, B, T)
    mask = (dims & scored.unsqueeze(-1) & batch.rows.view(m, b, 1, 1)).to(batch.x0.dtype)
    per_dim = weight * (denoised - batch.x0) ** 2 * mask
    return per_dim.sum(dim=(1, 2, 3)) / mask.sum(dim=(1, 2, 3)).clamp_min(1.0)


def clip_grad_norm_per_model(parameters: Iterable[nn.Parameter], max_norm: float) -> torch.Tensor:
    """``clip_grad_norm_`` applied to each model's slice (dim 0) of stacked parameters on its own:
    every model's gradient is scaled by ``min(1, max_norm / (norm + 1e-6))`` of its own norm.
    Returns the (M,) norms before clipping."""
    grads = [p.grad for p in parameters if p.grad is not None]
    norms = torch.stack([torch.linalg.vector_norm(g.flatten(1), dim=1) for g in grads])  # (P, M)
    total: torch.Tensor = torch.linalg.vector_norm(norms, dim=0)  # (M,)
    scale = (max_norm / (total + 1e-6)).clamp(max=1.0)
    for g in grads:
        g.mul_(scale.view(-1, *([1] * (g.dim() - 1))))
    return total


def _dim_masks(layouts: Sequence[TokenLayout], n_tokens: int, d_max: int) -> torch.Tensor:
    """(M, 1, T, D) bool: the real dimensions of each model's tokens."""
    dims = torch.zeros(len(layouts), 1, n_tokens, d_max, dtype=torch.bool)
    for m, layout in enumerate(layouts):
        dims[m, 0, : layout.n_tokens] = layout.dim_mask(d_max)
    return dims


def _padded_rows(model: StackedDenoiser, data: Sequence[torch.Tensor]) -> list[torch.Tensor]:
    """Flat (N_m, D_m) data -> (N_m, T_m, D_max) tokens, checked against the layouts."""
    if len(data) != len(model.layouts):
        raise ValueError(f"{len(data)} datasets for a stack of {len(model.layouts)} models")
    out = []
    for m, (rows, layout) in enumerate(zip(data, model.layouts, strict=True)):
        if rows.dim() != 2 or rows.shape[1] != layout.total_dim or rows.shape[0] < 1:
            raise ValueError(f"model {m}: data {tuple(rows.shape)} for a layout of {layout.total_dim} dims")
        out.append(layout.pad(rows, model.max_dim))
    return out


def evaluate_stacked_loss(
    model: StackedDenoiser, data: Sequence[torch.Tensor], seed: int = 0, n_noise: int = 4
) -> list[float]:
    """``evaluate_loss`` of every model on its own held-out rows (N_m, D_m), in one pass per
    noise draw: each model's mean loss with all tokens present."""
    padded = _padded_rows(model, data)
    t, d_max = model.network.n_tokens, model.max_dim
    dims = _dim_masks(model.layouts, t, d_max)
    generators = [torch.Generator().manual_seed(seed + 1) for _ in padded]
    total = torch.zeros(len(padded))
    with torch.no_grad():
        for _ in range(n_noise):
            total += stacked_dsm_loss(model, _held_out_batch(padded, model.layouts, t, generators), dims)
    return (total / n_noise).tolist()


def train_stacked(
    model: StackedDenoiser,
    data: Sequence[torch.Tensor],
    config: TrainConfig,
    val_data: Sequence[torch.Tensor] | None = None,
    on_step: StepCallback | None = None,
    val_every: int = 100,
) -> StackedTrainResult:
    """Fit each model of a stack to its own flat data (N_m, D_m), all in one optimiser step.

    The stack's statistics must already be set (``build_stack``). Every step draws
    ``config.batch_size`` rows per model and minimises the sum of the models' losses.
    """
    layouts = model.layouts
    padded = _padded_rows(model, data)
    if config.clean_share > 0 and not model.accepts_clean:
        raise ValueError("training with clean tokens needs a model built with DiTConfig(conditioning=True)")
    n_models, t, d_max = len(layouts), model.network.n_tokens, model.max_dim
    dims = _dim_masks(layouts, t, d_max)
    generators = [torch.Generator().manual_seed(config.seed) for _ in layouts]
    torch.manual_seed(config.seed)  # dropout inside the network
    model.train()
    ema = copy.deepcopy(model).eval()
    optimiser = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    result = StackedTrainResult(ema, [[] for _ in layouts], [[] for _ in layouts])
    for step in range(config.steps):
        batch = _training_batch(padded, layouts, t, config, generators)
        losses = stacked_dsm_loss(model, batch, dims)  # (M,)
        optimiser.zero_grad(set_to_none=True)
        losses.sum().backward()  # type: ignore[no-untyped-call]
        clip_grad_norm_per_model(model.parameters(), config.grad_clip)
        optimiser.step()
        _ema_update(ema, model, ema_decay_at(step, config.ema_decay))
        values = losses.detach().tolist()
        for m in range(n_models):
            result.losses[m].append(values[m])
        if on_step is not None:
            on_step(step, values)
        if val_data is not None and (step + 1) % val_every == 0:
            for m, loss in enumerate(evaluate_stacked_loss(ema, val_data, config.seed)):
                result.val_losses[m].append((step + 1, loss))
    model.eval()
    return result
