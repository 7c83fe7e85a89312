"""Skill denoisers: a token layout, normalisation statistics and EDM preconditioning.

The planner talks to every skill model through one padded, stacked interface
(``StackedDenoiser.denoise``); a single model is a stack of one. Analytic Gaussian models
(``gfc.diffusion.gaussian``) implement the same interface so the composition can be tested
against closed-form answers.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Literal, Protocol

import torch
from torch import nn

from gfc.diffusion.edm import edm_scalings, noise_conditioning
from gfc.diffusion.network import TOKEN_TYPES, DiTConfig, DiTStack

Precision = Literal["float32", "bfloat16"]


@dataclass(frozen=True)
class TokenLayout:
    """Token dims and types of one skill model, in token order (pre nodes, action, effects)."""

    dims: tuple[int, ...]
    types: tuple[str, ...]  # each in TOKEN_TYPES

    def __post_init__(self) -> None:
        if len(self.dims) != len(self.types) or not self.dims:
            raise ValueError("a layout needs one type per token and at least one token")
        bad = [t for t in self.types if t not in TOKEN_TYPES]
        if bad:
            raise ValueError(f"unknown token types {bad}; known: {TOKEN_TYPES}")

    @property
    def n_tokens(self) -> int:
        return len(self.dims)

    @property
    def total_dim(self) -> int:
        return sum(self.dims)

    @property
    def offsets(self) -> tuple[int, ...]:
        out, acc = [], 0
        for d in self.dims:
            out.append(acc)
            acc += d
        return tuple(out)

    def dim_mask(self, max_dim: int) -> torch.Tensor:
        """(T, max_dim) bool: which padded slots hold real dimensions."""
        return torch.arange(max_dim).unsqueeze(0) < torch.tensor(self.dims).unsqueeze(1)

    def pad(self, flat: torch.Tensor, max_dim: int) -> torch.Tensor:
        """(..., total_dim) -> (..., T, max_dim), zeros in padding."""
        out = flat.new_zeros(*flat.shape[:-1], self.n_tokens, max_dim)
        for t, (o, d) in enumerate(zip(self.offsets, self.dims, strict=True)):
            out[..., t, :d] = flat[..., o : o + d]
        return out

    def unpad(self, padded: torch.Tensor) -> torch.Tensor:
        """(..., T, max_dim) -> (..., total_dim)."""
        return torch.cat([padded[..., t, :d] for t, d in enumerate(self.dims)], dim=-1)


class StackedDenoiserProtocol(Protocol):
    """What the planner needs from a bank of M skill models."""

    layouts: list[TokenLayout]
    max_dim: int

    def denoise(
        self,
        x: torch.Tensor,
        sigma: torch.Tensor,
        present: torch.Tensor,
        roles: torch.Tensor | None = None,
        clean: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """x: (M, B, T, D_max), sigma: (M, B) or (M, 1), present: (M, B, T) bool, roles: (M, B, T) long
        (the model's token slot at each position; default 0..T-1), clean: (M, B, T) bool tokens
        given without noise (only for models that accept them) -> (M, B, T, D_max)."""
        ...

    def denoise_with_lone(
        self,
        x: torch.Tensor,
        sigma: torch.Tensor,
        present: torch.Tensor,
        lone_x: torch.Tensor,
        lone_roles: torch.Tensor,
        clean: torch.Tensor | None = None,
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Rows plus lone single-token queries (M, R, D) with roles (M, R); sigma (M, 1)."""
        ...

    @property
    def accepts_clean(self) -> bool:
        """Whether known nodes may be given clean (models trained with clean tokens)."""
        ...


class StackedDenoiser(nn.Module):
    """M DiT skill models with their statistics; EDM preconditioning per dimension.

    ``mean`` and ``std`` are (M, T, D_max) in each model's own frame and raw units; padded slots
    hold mean 0, std 1 and are ignored.
    """

    token_types: torch.Tensor  # (M, T) buffer
    mean: torch.Tensor  # (M, T, D_max) buffer
    std: torch.Tensor  # (M, T, D_max) buffer
    singles: list[StackedDenoiser] | None  # per-model stacks, for one-call-per-factor evaluation

    def __init__(
        self, network: DiTStack, layouts: list[TokenLayout], mean: torch.Tensor, std: torch.Tensor
    ) -> None:
        super().__init__()
        if len(layouts) != network.n_models:
            raise ValueError(f"{len(layouts)} layouts for {network.n_models} models")
        self.network = network
        self.layouts = layouts
        self.max_dim = network.config.max_token_dim
        n_tokens = network.n_tokens
        types = torch.zeros(len(layouts), n_tokens, dtype=torch.long)
        for m, layout in enumerate(layouts):
            if layout.n_tokens > n_tokens or max(layout.dims) > self.max_dim:
                raise ValueError(f"layout {layout} does not fit {n_tokens} tokens of {self.max_dim} dims")
            types[m, : layout.n_tokens] = torch.tensor([TOKEN_TYPES.index(t) for t in layout.types])
        self.register_buffer("token_types", types)  # (M, T)
        self.register_buffer("mean", mean)  # (M, T, D_max)
        self.register_buffer("std", std)  # (M, T, D_max)
        self.singles = None

    @property
    def config(self) -> DiTConfig:
        return self.network.config

    @property
    def accepts_clean(self) -> bool:
        """Whether the models were trained with clean conditioning tokens."""
        return self.network.config.conditioning

    def denoise(
        self,
        x: torch.Tensor,
        sigma: torch.Tensor,
        present: torch.Tensor,
        roles: torch.Tensor | None = None,
        clean: torch.Tensor | None = None,
    ) -> torch.Tensor:
        m, b, t, _ = x.shape
        if sigma.shape[1] > 1 and bool((sigma == sigma[:, :1]).all()):
            sigma = sigma[:, :1]  # one level per model: condition once per model, not per row
        if roles is None:
            roles = torch.arange(t).expand(m, b, t)
        models = torch.arange(m).view(m, 1, 1)
        mean = self.mean[models, roles]  # (M, B, T, D)
        std = self.std[models, roles]
        types = self.token_types[models, roles]  # (M, B, T)
        token_sigma = sigma[..., None, None]  # (M, B or 1, 1, 1)
        if clean is not None:  # clean tokens carry no noise: the identity (c_skip 1, c_out 0)
            token_sigma = torch.where(clean[..., None], 0.0, token_sigma)
        s = edm_scalings(token_sigma, std)
        centred = x - mean
        out = self.network(s.c_in * centred, noise_conditioning(sigma), roles, types, present, clean=clean)
        assert isinstance(out, torch.Tensor)
        # Preconditioning and the skip path stay in float32 whatever the network's precision:
        # at low noise the skip path carries almost all of the output.
        return mean + s.c_skip * centred + s.c_out * out.to(x.dtype)

    def denoise_with_lone(
        self,
        x: torch.Tensor,
        sigma: torch.Tensor,
        present: torch.Tensor,
        lone_x: torch.Tensor,
        lone_roles: torch.Tensor,
        clean: torch.Tensor | None = None,
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Rows and lone tokens (single-token marginal queries) in one network pass.

        x: (M, B, T, D), sigma: (M, 1), present: (M, B, T); lone_x: (M, R, D), lone_roles:
        (M, R) -> ((M, B, T, D), (M, R, D)).
        """
        m, b, t, _ = x.shape
        roles = torch.arange(t).expand(m, b, t)
        models = torch.arange(m)
        rows_mean, rows_std = self.mean[:, :t].unsqueeze(1), self.std[:, :t].unsqueeze(1)  # (M,1,T,D)
        lone_mean = self.mean[models.view(m, 1), lone_roles]  # (M, R, D)
        lone_std = self.std[models.view(m, 1), lone_roles]
        rows_sigma = sigma[..., None, None]
        if clean is not None:
            rows_sigma = torch.where(clean[..., None], 0.0, rows_sigma)
        rows_s = edm_scalings(rows_sigma, rows_std)
        lone_s = edm_scalings(sigma[..., None], lone_std)
        rows_centred, lone_centred = x - rows_mean, lone_x - lone_mean
        types = self.token_types[:, :t].unsqueeze(1).expand(m, b, t)
        lone_types = self.token_types[models.view(m, 1), lone_roles]
        out = self.network(
            rows_s.c_in * rows_centred,
            noise_conditioning(sigma),
            roles,
            types,
            present,
            lone=(lone_s.c_in * lone_centred, lone_roles, lone_types),
            clean=clean,
        )
        assert isinstance(out, tuple)
        rows_out, lone_out = out
        rows = rows_mean + rows_s.c_skip * rows_centred + rows_s.c_out * rows_out.to(x.dtype)
        lone = lone_mean + lone_s.c_skip * lone_centred + lone_s.c_out * lone_out.to(x.dtype)
        return rows, lone

    @property
    def precision(self) -> Precision:
        return "bfloat16" if self.network.enc_w.dtype == torch.bfloat16 else "float32"

    def with_precision(self, precision: Precision) -> StackedDenoiser:
        """A copy whose network weights are stored in ``precision`` (bfloat16 halves matmul time
        on CPUs with AVX512-BF16; statistics and preconditioning stay float32)."""
        network = copy.deepcopy(self.network).to(torch.bfloat16 if precision == "bfloat16" else torch.float32)
        out = StackedDenoiser(network, self.layouts, self.mean, self.std)
        return out.eval()

    @staticmethod
    def concatenate(models: list[StackedDenoiser]) -> StackedDenoiser:
        """Stack several banks into one (all of one network size) for one-pass evaluation."""
        network = DiTStack.concatenate([m.network for m in models])
        t, d = network.n_tokens, network.config.max_token_dim

        def padded(buffers: list[torch.Tensor], fill: float) -> torch.Tensor:
            out = torch.full((sum(b.shape[0] for b in buffers), t, d), fill)
            row = 0
            for b in buffers:
                out[row : row + b.shape[0], : b.shape[1]] = b
                row += b.shape[0]
            return out

        layouts = [layout for m in models for layout in m.layouts]
        mean = padded([m.mean for m in models], 0.0)
        std = padded([m.std for m in models], 1.0)
        return StackedDenoiser(network, layouts, mean, std).train(models[0].training)


def single_model(
    layout: TokenLayout,
    config: DiTConfig | None = None,
    mean: torch.Tensor | None = None,
    std: torch.Tensor | None = None,
) -> StackedDenoiser:
    """A stack of one model. ``mean``/``std``: flat (total_dim,) statistics, default 0 and 0.5."""
    config = config or DiTConfig()
    flat_mean = mean if mean is not None else torch.zeros(layout.total_dim)
    flat_std = std if std is not None else torch.full((layout.total_dim,), 0.5)
    padded_mean = layout.pad(flat_mean, config.max_token_dim).unsqueeze(0)
    padded_std = layout.pad(flat_std, config.max_token_dim)
    padded_std = torch.where(layout.dim_mask(config.max_token_dim), padded_std, 1.0).unsqueeze(0)
    network = DiTStack(config, n_models=1, n_tokens=layout.n_tokens)
    return StackedDenoiser(network, [layout], padded_mean, padded_std)


def denoise_flat(
    model: StackedDenoiserProtocol,
    x: torch.Tensor,
    sigma: torch.Tensor,
    present: torch.Tensor | None = None,
) -> torch.Tensor:
    """Evaluate a stack of one model on flat inputs. x: (B, D), sigma: (B,) -> (B, D)."""
    if len(model.layouts) != 1:
        raise ValueError("denoise_flat takes a stack of one model")
    layout = model.layouts[0]
    b = x.shape[0]
    if present is None:
        present = torch.ones(b, layout.n_tokens, dtype=torch.bool)
    out = model.denoise(layout.pad(x, model.max_dim).unsqueeze(0), sigma.unsqueeze(0), present.unsqueeze(0))
    return layout.unpad(out[0])
