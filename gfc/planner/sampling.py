"""Reverse diffusion over the whole factor graph: the composed score handed to a plain sampler."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from gfc.diffusion.edm import SIGMA_MAX, SIGMA_MIN, karras_sigmas
from gfc.diffusion.samplers import SAMPLERS
from gfc.planner.composed import ComposedScore
from gfc.planner.layout import VariableLayout


@dataclass(frozen=True)
class SamplingSettings:
    steps: int = 50  # reverse diffusion steps
    sampler: str = "euler"  # "euler" or "heun"
    churn: float = 0.0  # EDM S_churn: stochasticity per step (0 = deterministic ODE)
    sigma_min: float = SIGMA_MIN
    sigma_max: float = SIGMA_MAX
    per_factor: bool = False  # one network call per factor instead of one per step (baseline)
    corrector_steps: int = 0  # Langevin corrector steps after each step (predictor-corrector)
    corrector_snr: float = 0.1


def initial_noise(
    candidates: int, layout: VariableLayout, sigma_max: float, generator: torch.Generator
) -> tuple[torch.Tensor, torch.Tensor]:
    """The random start of a plan: z at sigma_max (B, N) and the known nodes' noise (B, K)."""
    z = torch.randn(candidates, layout.free_dim, generator=generator) * sigma_max
    known_noise = torch.randn(candidates, layout.known_dim, generator=generator)
    return z, known_noise


def sample_graph(
    composed: ComposedScore,
    candidates: int,
    settings: SamplingSettings,
    generator: torch.Generator,
    z0: torch.Tensor | None = None,
    known_noise: torch.Tensor | None = None,
) -> torch.Tensor:
    """Draw ``candidates`` joint samples of all free variables. Returns z: (B, N).

    ``z0`` and ``known_noise`` (from ``initial_noise``) fix the random start; by default they
    are drawn from ``generator``.
    """
    if settings.sampler not in SAMPLERS:
        raise ValueError(f"unknown sampler {settings.sampler!r}; choose from {sorted(SAMPLERS)}")
    sigmas = karras_sigmas(settings.steps, settings.sigma_min, settings.sigma_max)
    if z0 is None or known_noise is None:
        z0, known_noise = initial_noise(candidates, composed.layout, float(sigmas[0]), generator)
    z = z0

    def denoiser(x: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
        # D(x; sigma) = x + sigma^2 * score(x; sigma)  (Tweedie)
        return x + sigma**2 * composed.score(x, sigma, known_noise, settings.per_factor)

    with torch.inference_mode(False), torch.no_grad():
        return SAMPLERS[settings.sampler](
            denoiser,
            z,
            sigmas,
            churn=settings.churn,
            generator=generator,
            corrector_steps=settings.corrector_steps,
            corrector_snr=settings.corrector_snr,
        )
