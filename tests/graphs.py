"""Small hand-built factor graphs over plain vectors, for analytic tests of the composition."""

from __future__ import annotations

import numpy as np
import torch

from gfc.diffusion.denoiser import TokenLayout
from gfc.diffusion.gaussian import GaussianFactor
from gfc.plan.graph import (
    ActionVariable,
    CompiledPlan,
    FactorToken,
    NodeVersion,
    SpatialFactor,
    TemporalFactor,
)

IDENTITY = tuple(tuple(float(i == j) for j in range(4)) for i in range(4))


def vector_node(
    node_id: int, entity: str, version: int, dim: int, value: tuple[float, ...] | None = None
) -> NodeVersion:
    return NodeVersion(node_id, entity, version, "object", "vector", dim, value is not None, value)


def factor(
    step: int,
    model: str,
    pre: list[int],
    action: int | None,
    effect: list[int],
    dims: dict[int, int],
    action_dim: int = 1,
) -> TemporalFactor:
    tokens = [FactorToken("object", "pre", dims[n], node=n) for n in pre]
    if action is not None:
        tokens.append(FactorToken("action", "action", action_dim, action=action))
    tokens += [FactorToken("object", "effect", dims[n], node=n) for n in effect]
    return TemporalFactor(step, "skill", model, "robot", None, tuple(tokens), IDENTITY)


def layout_of(f: TemporalFactor) -> TokenLayout:
    return TokenLayout(
        tuple(t.dim for t in f.tokens),
        tuple("action" if t.action is not None else "object" for t in f.tokens),
    )


def random_gaussian(layout: TokenLayout, seed: int, scale: float = 0.6, floor: float = 0.3) -> GaussianFactor:
    g = torch.Generator().manual_seed(seed)
    n = layout.total_dim
    a = torch.randn(n, n, generator=g, dtype=torch.float64) * scale
    cov = a @ a.T + floor * torch.eye(n, dtype=torch.float64)
    mean = torch.randn(n, generator=g, dtype=torch.float64) * 0.5
    return GaussianFactor(layout, mean, cov)


def plan_of(
    nodes: list[NodeVersion],
    n_actions: int,
    factors: list[TemporalFactor],
    spatial: tuple[SpatialFactor, ...] = (),
) -> CompiledPlan:
    actions = tuple(ActionVariable(i, i, ("a",)) for i in range(n_actions))
    return CompiledPlan(tuple(nodes), actions, tuple(factors), spatial, tuple((f.step,) for f in factors))


class InformationForm:
    """Accumulates a Gaussian product in information form over named flat variables."""

    def __init__(self, n: int) -> None:
        self.precision = np.zeros((n, n))
        self.shift = np.zeros(n)

    def add(self, mean: np.ndarray, cov: np.ndarray, idx: list[int], coeff: float = 1.0) -> None:
        p = np.linalg.inv(cov)
        self.precision[np.ix_(idx, idx)] += coeff * p
        self.shift[idx] += coeff * p @ mean

    def add_factor(self, gf: GaussianFactor, idx: list[int]) -> None:
        self.add(gf.mean.numpy(), gf.cov.numpy(), idx)

    def add_marginal(self, gf: GaussianFactor, dims: list[int], idx: list[int], coeff: float) -> None:
        self.add(gf.mean.numpy()[dims], gf.cov.numpy()[np.ix_(dims, dims)], idx, coeff)

    def moments(self) -> tuple[np.ndarray, np.ndarray]:
        assert np.linalg.eigvalsh(self.precision).min() > 0, "target is not a proper Gaussian"
        cov = np.linalg.inv(self.precision)
        return cov @ self.shift, cov
