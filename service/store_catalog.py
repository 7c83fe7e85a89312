"""The catalogue of a skill store: versions, aliases and per-version readiness."""

from __future__ import annotations

from service.catalog import probe
from service.schemas import SkillSummary, SkillVersion
from skill_store import SkillStore, StoreLibrary
from skill_store.store import ResolvedRef


class StoreCatalog:
    def __init__(self, store: SkillStore, library: StoreLibrary) -> None:
        self.store = store
        self.library = library

    def describe(self, name: str) -> SkillSummary:
        state = self.store.state(name)  # SkillNotFoundError is a KeyError
        if not state.versions:
            raise KeyError(name)
        versions = []
        for version in state.versions:
            try:
                probe(self.library.model(ResolvedRef(name, version)))
                versions.append(SkillVersion(name=name, version=str(version), ready=True))
            except Exception as exc:  # a broken version is reported, not raised
                versions.append(SkillVersion(name=name, version=str(version), ready=False, detail=str(exc)))
        return SkillSummary(
            name=name, versions=versions, aliases={a: str(v) for a, v in state.aliases.items()}
        )

    def list_skills(self) -> list[SkillSummary]:
        return [self.describe(name) for name in self.store.skills()]
