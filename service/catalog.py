"""What the service knows about its skills: a catalogue next to the planner's library."""

from __future__ import annotations

from typing import Protocol

import torch

from gfc.diffusion.denoiser import StackedDenoiser
from gfc.plan.graph import ActionVariable, CompiledPlan, FactorToken, NodeVersion, TemporalFactor
from gfc.planner.composed import ComposedScore
from gfc.planner.library import InMemoryLibrary, stack_models
from gfc.planner.sampling import SamplingSettings, sample_graph
from service.schemas import SkillSummary, SkillVersion


class SkillCatalog(Protocol):
    def list_skills(self) -> list[SkillSummary]: ...

    def describe(self, name: str) -> SkillSummary:
        """Raises KeyError for an unknown skill."""
        ...


def probe(model: StackedDenoiser) -> None:
    """A tiny plan samples: one factor of this model over free nodes, two sampling steps, two
    candidates, through the planner's composed sampler. Raises if anything fails or the samples
    are not finite."""
    layout = model.layouts[0]
    nodes: list[NodeVersion] = []
    tokens: list[FactorToken] = []
    for t, (dim, kind) in enumerate(zip(layout.dims, layout.types, strict=True)):
        if kind == "action":
            tokens.append(FactorToken("action", "action", dim, action=0))
        else:
            nodes.append(NodeVersion(len(nodes), f"e{t}", 1, "object", "probe", dim, known=False))
            tokens.append(FactorToken("object", "pre", dim, node=len(nodes) - 1))
    actions = tuple(
        ActionVariable(0, 0, tuple(f"a{i}" for i in range(d)))
        for d, k in zip(layout.dims, layout.types, strict=True)
        if k == "action"
    )
    identity = tuple(tuple(float(i == j) for j in range(4)) for i in range(4))
    factor = TemporalFactor(0, "probe", "probe", "robot", None, tuple(tokens), identity)
    graph = CompiledPlan(tuple(nodes), actions, (factor,), (), ((0,),))
    composed = ComposedScore(graph, stack_models([model]))
    z = sample_graph(composed, 2, SamplingSettings(steps=2), torch.Generator().manual_seed(0))
    if not bool(torch.isfinite(z).all()):
        raise ValueError("the model's samples are not finite")


class InMemoryCatalog:
    """Catalogue of an ``InMemoryLibrary`` (tests, benchmarks): one version per skill."""

    def __init__(self, library: InMemoryLibrary) -> None:
        self.library = library
        self._checked: dict[str, str | None] = {}

    def describe(self, name: str) -> SkillSummary:
        model = self.library.models.get(name)
        if model is None:
            raise KeyError(name)
        if name not in self._checked:
            try:
                probe(model)
                self._checked[name] = None
            except Exception as exc:  # a broken model is reported, not raised
                self._checked[name] = str(exc)
        problem = self._checked[name]
        version = SkillVersion(name=name, version="in-memory", ready=problem is None, detail=problem or "")
        return SkillSummary(name=name, versions=[version], aliases={"latest": "in-memory"})

    def list_skills(self) -> list[SkillSummary]:
        return [self.describe(name) for name in sorted(self.library.models)]
