"""EDM (Karras et al. 2022) preconditioning, noise schedule and denoising score-matching loss.

Noise is variance exploding and isotropic *in the raw data units*: ``x = x0 + sigma * eps``.
This matters for composition: a node shared by two skill models must carry the same noise in
both, so a model may not rescale dimensions before noising. Per-dimension statistics enter only
through the preconditioning, which is EDM's with a per-dimension ``sigma_data``:

    c_skip = sd^2 / (sigma^2 + sd^2)      c_out = sigma * sd / sqrt(sigma^2 + sd^2)
    c_in   = 1 / sqrt(sigma^2 + sd^2)     c_noise = ln(sigma) / 4
    D(x; sigma) = mean + c_skip * (x - mean) + c_out * F(c_in * (x - mean), c_noise)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

SIGMA_MIN = 0.002
SIGMA_MAX = 3.0
RHO = 7.0


@dataclass(frozen=True)
class Scalings:
    c_skip: torch.Tensor
    c_out: torch.Tensor
    c_in: torch.Tensor


def edm_scalings(sigma: torch.Tensor, sigma_data: torch.Tensor) -> Scalings:
    """``sigma`` and ``sigma_data`` broadcast against each other (e.g. (B, 1) and (D,))."""
    total = sigma**2 + sigma_data**2
    return Scalings(
        c_skip=sigma_data**2 / total,
        c_out=sigma * sigma_data / total.sqrt(),
        c_in=total.rsqrt(),
    )


def noise_conditioning(sigma: torch.Tensor) -> torch.Tensor:
    """EDM's ``c_noise``: what the network sees of the noise level."""
    return sigma.log() / 4


def karras_sigmas(
    n: int,
    sigma_min: float = SIGMA_MIN,
    sigma_max: float = SIGMA_MAX,
    rho: float = RHO,
    dtype: torch.dtype = torch.float32,
) -> torch.Tensor:
    """``n`` decreasing noise levels from ``sigma_max`` to ``sigma_min``, then a final 0. (n+1,)"""
    if n < 1:
        raise ValueError(f"need at least one sampling step, got {n}")
    ramp = torch.linspace(0, 1, n, dtype=torch.float64)
    if n == 1:
        ramp = torch.zeros(1, dtype=torch.float64)
    min_inv, max_inv = sigma_min ** (1 / rho), sigma_max ** (1 / rho)
    sigmas = (max_inv + ramp * (min_inv - max_inv)) ** rho
    return torch.cat([sigmas, sigmas.new_zeros(1)]).to(dtype)


def sample_training_sigmas(
    n: int, generator: torch.Generator | None = None, p_mean: float = -1.2, p_std: float = 1.2
) -> torch.Tensor:
    """Log-normal training noise levels (EDM's P_mean, P_std). (n,)"""
    return (torch.randn(n, generator=generator) * p_std + p_mean).exp()


def edm_loss_weight(sigma: torch.Tensor, sigma_data: torch.Tensor) -> torch.Tensor:
    """``lambda(sigma) = 1 / c_out^2``: makes the network's target unit variance at every level."""
    return (sigma**2 + sigma_data**2) / (sigma * sigma_data) ** 2


def denoising_loss(
    denoised: torch.Tensor,
    clean: torch.Tensor,
    sigma: torch.Tensor,
    sigma_data: torch.Tensor,
    mask: torch.Tensor | None = None,
) -> torch.Tensor:
    """Weighted denoising score-matching loss ``lambda * |D(x0 + sigma eps) - x0|^2``.

    ``denoised``, ``clean``: (B, D); ``sigma``: (B, 1); ``sigma_data``: (D,) or (B, D);
    ``mask``: (B, D), 1 where a dimension takes part (its token was present). Returns a scalar:
    the mean over participating dimensions.
    """
    per_dim = edm_loss_weight(sigma, sigma_data) * (denoised - clean) ** 2  # (B, D)
    if mask is None:
        return per_dim.mean()
    return (per_dim * mask).sum() / mask.sum().clamp_min(1.0)


def log_sigma_span() -> float:
    """Width of the sampling schedule in nats (used to size sinusoidal embeddings)."""
    return math.log(SIGMA_MAX / SIGMA_MIN)
