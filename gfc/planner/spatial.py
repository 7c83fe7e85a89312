"""The spatial factors of one plan on the joint vector z: residuals, ranking cost, guidance."""

from __future__ import annotations

import torch

from gfc.constraints import scaled_residual
from gfc.plan.graph import CompiledPlan, SpatialFactor
from gfc.planner.layout import VariableLayout, known_values_of


class SpatialTerms:
    """Spatial factors (constraints and goal) read from z (free nodes) and the known values."""

    def __init__(
        self, plan: CompiledPlan, layout: VariableLayout, known_values: torch.Tensor | None = None
    ) -> None:
        self.layout = layout
        self.known_values = known_values if known_values is not None else known_values_of(plan, layout)
        self.factors: list[tuple[SpatialFactor, list[tuple[bool, int, int]]]] = [
            (
                f,
                [layout.locate(plan.nodes[n]) for n in f.nodes]
                + [(False, layout.action_offset[a], plan.actions[a].dim) for a in f.actions],
            )
            for f in plan.spatial
        ]

    def __bool__(self) -> bool:
        return bool(self.factors)

    def residuals(self, z: torch.Tensor) -> list[torch.Tensor]:
        """Tolerance-scaled residuals of every spatial factor. Each (B, R_f)."""
        out = []
        for factor, where in self.factors:
            nodes = [
                self.known_values[o : o + d].expand(z.shape[0], d) if known else z[:, o : o + d]
                for known, o, d in where
            ]
            out.append(scaled_residual(factor.type, nodes, factor.params))
        return out

    def cost(self, z: torch.Tensor) -> torch.Tensor:
        """Per-candidate energy ``sum weight/2 |r|^2`` of all spatial factors. (B,)"""
        cost = z.new_zeros(z.shape[0])
        for (factor, _), r in zip(self.factors, self.residuals(z), strict=True):
            cost = cost + 0.5 * factor.params.get("weight", 1.0) * (r**2).sum(-1)
        return cost

    def guidance(self, z: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
        """Score of the noised spatial factors: ``-grad sum w/(1 + g w sigma^2) |r|^2 / 2``."""
        if not self.factors:
            return torch.zeros_like(z)
        with torch.enable_grad():
            zg = z.detach().requires_grad_(True)
            energy = zg.new_zeros(())
            for (factor, _), r in zip(self.factors, self.residuals(zg), strict=True):
                weight = factor.params.get("weight", 1.0)
                precision = weight / factor.params.get("tolerance", 0.01) ** 2
                # residuals are already divided by the tolerance: E = weight/2 |r_scaled|^2
                noised = weight / (1.0 + factor.params.get("gain", 1.0) * precision * sigma**2)
                energy = energy + 0.5 * (noised * (r**2).sum(-1)).sum()
            (grad,) = torch.autograd.grad(energy, zg)
        return -grad
