"""Samplers as pure functions with one signature (k-diffusion style).

``denoiser(x, sigma) -> x0_hat`` where ``x``: (B, D) and ``sigma`` a 0-d tensor. A composed
factor-graph denoiser (``gfc.planner``) is "just another model" handed to these functions.
The random source is injected (``generator``) so every request has its own stream.

Both samplers implement EDM's Algorithm 2: optional churn (``churn > 0``) first raises the noise
of the current sample from ``sigma_i`` to ``sigma_hat = sigma_i * (1 + gamma)`` with fresh noise
(a Langevin-like correction), then takes an Euler step of the probability-flow ODE
``dx/dsigma = (x - D(x; sigma)) / sigma``; Heun adds a trapezoidal correction.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

Denoiser = Callable[[torch.Tensor, torch.Tensor], torch.Tensor]
Callback = Callable[[int, torch.Tensor, torch.Tensor, torch.Tensor], None]  # i, sigma, x, x0_hat


def _churn_gamma(sigma: float, n_steps: int, churn: float, s_tmin: float, s_tmax: float) -> float:
    if churn <= 0 or not s_tmin <= sigma <= s_tmax:
        return 0.0
    return min(churn / n_steps, math.sqrt(2) - 1)


def _raise_noise(
    x: torch.Tensor, sigma: torch.Tensor, gamma: float, generator: torch.Generator | None
) -> tuple[torch.Tensor, torch.Tensor]:
    sigma_hat = sigma * (1 + gamma)
    if gamma > 0:
        eps = torch.randn(x.shape, generator=generator, dtype=x.dtype, device=x.device)
        x = x + eps * (sigma_hat**2 - sigma**2).sqrt()
    return x, sigma_hat


def langevin_corrector(
    denoiser: Denoiser,
    x: torch.Tensor,
    sigma: torch.Tensor,
    n_steps: int,
    snr: float,
    generator: torch.Generator | None = None,
) -> torch.Tensor:
    """Unadjusted Langevin steps at a fixed noise level (Song et al. 2021's corrector).

    The step size follows the signal-to-noise rule ``eps = 2 (snr |xi| / |score|)^2`` per sample,
    so it adapts to the local stiffness. Composed (product) distributions need such MCMC steps to
    be sampled correctly: the sum of noised factor scores is not the score of the noised product
    (Du et al. 2023, "Reduce, Reuse, Recycle").
    """
    if n_steps <= 0 or float(sigma) <= 0:
        return x
    for _ in range(n_steps):
        score = (denoiser(x, sigma) - x) / sigma**2
        xi = torch.randn(x.shape, generator=generator, dtype=x.dtype, device=x.device)
        eps = snr * sigma**2
        x = x + eps * score + (2 * eps).sqrt() * xi
    return x


def _sample(
    denoiser: Denoiser,
    x: torch.Tensor,
    sigmas: torch.Tensor,
    heun: bool,
    churn: float,
    s_tmin: float,
    s_tmax: float,
    generator: torch.Generator | None,
    callback: Callback | None,
    corrector_steps: int,
    corrector_snr: float,
) -> torch.Tensor:
    n_steps = len(sigmas) - 1
    for i in range(n_steps):
        gamma = _churn_gamma(float(sigmas[i]), n_steps, churn, s_tmin, s_tmax)
        x, sigma_hat = _raise_noise(x, sigmas[i], gamma, generator)
        x0_hat = denoiser(x, sigma_hat)
        if callback is not None:
            callback(i, sigma_hat, x, x0_hat)
        d = (x - x0_hat) / sigma_hat  # dx/dsigma
        dt = sigmas[i + 1] - sigma_hat
        x_next = x + d * dt
        if heun and sigmas[i + 1] > 0:  # trapezoidal correction; the last step into 0 stays Euler
            d_next = (x_next - denoiser(x_next, sigmas[i + 1])) / sigmas[i + 1]
            x_next = x + (d + d_next) / 2 * dt
        x = langevin_corrector(denoiser, x_next, sigmas[i + 1], corrector_steps, corrector_snr, generator)
    return x


def sample_euler(
    denoiser: Denoiser,
    x: torch.Tensor,
    sigmas: torch.Tensor,
    *,
    churn: float = 0.0,
    s_tmin: float = 0.0,
    s_tmax: float = float("inf"),
    generator: torch.Generator | None = None,
    callback: Callback | None = None,
    corrector_steps: int = 0,
    corrector_snr: float = 0.1,
) -> torch.Tensor:
    """Euler steps along ``sigmas`` (decreasing, ending in 0). ``x`` starts at ``sigmas[0]``."""
    return _sample(
        denoiser, x, sigmas, False, churn, s_tmin, s_tmax, generator, callback, corrector_steps, corrector_snr
    )


def sample_heun(
    denoiser: Denoiser,
    x: torch.Tensor,
    sigmas: torch.Tensor,
    *,
    churn: float = 0.0,
    s_tmin: float = 0.0,
    s_tmax: float = float("inf"),
    generator: torch.Generator | None = None,
    callback: Callback | None = None,
    corrector_steps: int = 0,
    corrector_snr: float = 0.1,
) -> torch.Tensor:
    """Heun (2nd order) steps; the last step into sigma = 0 is an Euler step, as in EDM."""
    return _sample(
        denoiser, x, sigmas, True, churn, s_tmin, s_tmax, generator, callback, corrector_steps, corrector_snr
    )


SAMPLERS: dict[str, Callable[..., torch.Tensor]] = {"euler": sample_euler, "heun": sample_heun}
