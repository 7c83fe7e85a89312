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
        self._checked: dict[ResolvedRef, str | None] = {}  # versions are immutable: probe once

    def describe(self, name: str) -> SkillSummary:
        state = self.store.state(name)  # SkillNotFoundError is a KeyError
        if not state.versions:
            raise KeyError(name)
        versions = []
        for version in state.versions:
            ref = ResolvedRef(name, version)
            if ref not in self._checked:
                try:
                    probe(self.library.model(ref))
                    self._checked[ref] = None
                except Exception as exc:  # a broken version is reported, not raised
                    self._checked[ref] = str(exc)
            problem = self._checked[ref]
            versions.append(
                SkillVersion(name=name, version=str(version), ready=problem is None, detail=problem or "")
            )
        return SkillSummary(
            name=name, versions=versions, aliases={a: str(v) for a, v in state.aliases.items()}
        )

    def list_skills(self) -> list[SkillSummary]:
        return [self.describe(name) for name in self.store.skills()]
