"""Where the planner gets skill models: a library resolves model references to one stacked bank.

The skill store (``skill_store``) implements the same protocol for versioned checkpoints; an
in-memory library serves tests and benchmarks.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Protocol

import torch

from gfc.diffusion.denoiser import (
    Precision,
    StackedDenoiser,
    StackedDenoiserProtocol,
    TokenLayout,
    single_model,
)
from gfc.diffusion.network import DiTConfig
from gfc.plan.graph import CompiledPlan
from gfc.skills.signatures import skill_spec


@dataclass
class Bank:
    """The models of one plan's factors, stacked in factor order (a model used twice, twice)."""

    denoiser: StackedDenoiserProtocol
    versions: dict[str, str]  # model reference -> resolved "name@version"


class SkillLibrary(Protocol):
    def bank(self, refs: list[str]) -> Bank:
        """Stack the models for these references, in order (``pick.hammer``, ``pick.hammer@3``,
        ``pick.hammer@production``)."""
        ...


def stack_models(models: list[StackedDenoiser], precision: Precision = "float32") -> StackedDenoiser:
    """Stack per-factor models into one bank; ``singles`` keeps them for per-factor evaluation."""
    bank = StackedDenoiser.concatenate(models)
    singles = list(models)
    if precision != "float32":
        bank = bank.with_precision(precision)
        singles = [m.with_precision(precision) for m in singles]
    bank.singles = singles
    return bank.eval()


class InMemoryLibrary:
    """Models held in memory by name; banks are cached by the set of names they stack."""

    def __init__(
        self,
        models: dict[str, StackedDenoiser],
        cache_size: int = 32,
        precision: Precision = "float32",
    ) -> None:
        self.models = models
        self.precision = precision
        self._cache: OrderedDict[tuple[str, ...], StackedDenoiser] = OrderedDict()
        self._cache_size = cache_size

    def bank(self, refs: list[str]) -> Bank:
        names = tuple(refs)
        missing = sorted({n for n in names if n.split("@")[0] not in self.models})
        if missing:
            raise KeyError(
                f"no skill model for {', '.join(missing)} (have: {', '.join(sorted(self.models))})"
            )
        stacked = self._cache.get(names)
        if stacked is None:
            stacked = stack_models([self.models[n.split("@")[0]] for n in names], self.precision)
            self._cache[names] = stacked
            if len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(names)
        return Bank(stacked, {n: n.split("@")[0] for n in names})


def layout_for_factor(plan: CompiledPlan, step: int) -> TokenLayout:
    """The token layout a plan step's skill model must have."""
    factor = next(f for f in plan.temporal if f.step == step)
    spec = skill_spec(factor.skill)
    kinds: dict[str, str] = {t.role: t.kind for t in spec.tokens()}
    types = tuple(kinds.get(t.role, "action") for t in factor.tokens)
    return TokenLayout(tuple(t.dim for t in factor.tokens), types)


def random_library(plan: CompiledPlan, config: DiTConfig | None = None, seed: int = 0) -> InMemoryLibrary:
    """Randomly initialised DiT models for every skill model a plan names (benchmarks, smoke tests).

    Weights that DiT initialises at zero (adaLN-Zero, the output layer) are drawn at random too,
    so every layer does real work.
    """
    generator = torch.Generator().manual_seed(seed)
    models: dict[str, StackedDenoiser] = {}
    for factor in plan.temporal:
        name = factor.model.split("@")[0]
        if name in models:
            continue
        layout = layout_for_factor(plan, factor.step)
        model = single_model(layout, config)
        with torch.no_grad():
            for param in model.parameters():
                param.copy_(torch.randn(param.shape, generator=generator) * 0.02)
        models[name] = model.eval()
    return InMemoryLibrary(models)
