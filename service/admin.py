"""Management of a store-backed service: load, unload and alias skill versions (token only)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from skill_store import SkillStore, StoreLibrary
from skill_store.store import ResolvedRef


@dataclass
class SkillAdmin:
    store: SkillStore
    library: StoreLibrary

    def load(self, name: str, version: int | None) -> str:
        """Load (and check) a version into the cache now, instead of on the first request."""
        resolved = self.library.resolve(name if version is None else f"{name}@{version}")
        self.library.model(resolved)
        return str(resolved)

    def unload(self, name: str, version: int | None) -> int:
        return self.library.unload(name, version)

    def alias(self, name: str, alias: str, version: int, reason: str | None) -> dict[str, Any]:
        entry = self.store.set_alias(str(ResolvedRef(name, version)), alias, reason)
        self.library.refresh()  # the move takes effect for the next request
        return {"name": name, "alias": alias, "version": version, "audit": str(entry)}
