"""What the service knows about its skills: a catalogue next to the planner's library."""

from __future__ import annotations

from typing import Protocol

import torch

from gfc.diffusion.denoiser import StackedDenoiser, denoise_flat
from gfc.planner.library import InMemoryLibrary
from service.schemas import SkillSummary, SkillVersion


class SkillCatalog(Protocol):
    def list_skills(self) -> list[SkillSummary]: ...

    def describe(self, name: str) -> SkillSummary:
        """Raises KeyError for an unknown skill."""
        ...


def probe(model: StackedDenoiser) -> None:
    """One denoising call on zeros: the model loads, runs and returns finite numbers."""
    layout = model.layouts[0]
    with torch.no_grad():
        out = denoise_flat(model, torch.zeros(1, layout.total_dim), torch.ones(1))
    if not bool(torch.isfinite(out).all()):
        raise ValueError("the model returns non-finite values")


class InMemoryCatalog:
    """Catalogue of an ``InMemoryLibrary`` (tests, benchmarks): one version per skill."""

    def __init__(self, library: InMemoryLibrary) -> None:
        self.library = library

    def describe(self, name: str) -> SkillSummary:
        model = self.library.models.get(name)
        if model is None:
            raise KeyError(name)
        try:
            probe(model)
            version = SkillVersion(name=name, version="in-memory", ready=True)
        except Exception as exc:  # a broken model is reported, not raised
            version = SkillVersion(name=name, version="in-memory", ready=False, detail=str(exc))
        return SkillSummary(name=name, versions=[version], aliases={"latest": "in-memory"})

    def list_skills(self) -> list[SkillSummary]:
        return [self.describe(name) for name in sorted(self.library.models)]
