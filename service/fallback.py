"""Serve the newest skill version that passes its checks; refuse (and report) corrupted ones.

A reference by name or alias (``pick.hammer``, ``pick.hammer@production``) that resolves to a
version failing its integrity checks falls back to the newest older version that passes, so a
bad publish never takes planning down. A reference to an explicit version gets no fallback:
the caller asked for exactly that one.
"""

from __future__ import annotations

import logging
import threading

from gfc.planner.library import Bank
from skill_store import IntegrityError, StoreLibrary, parse_ref
from skill_store.store import ResolvedRef

log = logging.getLogger("gfc.service")


class FallbackLibrary:
    """Implements ``SkillLibrary`` over a ``StoreLibrary`` with that fallback policy."""

    def __init__(self, library: StoreLibrary) -> None:
        self.library = library
        self.refused: dict[str, str] = {}  # "name@version" -> why it was refused
        self._lock = threading.Lock()

    def bank(self, refs: list[str]) -> Bank:
        pinned = [self._pin(ref) for ref in refs]
        bank = self.library.bank(pinned)
        return Bank(bank.denoiser, {ref: bank.versions[p] for ref, p in zip(refs, pinned, strict=True)})

    def _pin(self, ref: str) -> str:
        resolved = self.library.resolve(ref)
        if parse_ref(ref).version is not None:
            return str(resolved)  # explicit: load it or fail
        try:
            self.library.model(resolved)
            return str(resolved)
        except IntegrityError as exc:
            self._refuse(resolved, exc)
        versions = self.library.store.versions(resolved.name)
        for version in sorted((v for v in versions if v < resolved.version), reverse=True):
            older = ResolvedRef(resolved.name, version)
            try:
                self.library.model(older)
            except IntegrityError as exc:
                self._refuse(older, exc)
                continue
            return str(older)
        raise IntegrityError(f"every version of {resolved.name} up to {resolved.version} fails its checks")

    def _refuse(self, resolved: ResolvedRef, exc: Exception) -> None:
        with self._lock:
            first = str(resolved) not in self.refused
            self.refused[str(resolved)] = str(exc)
        if first:
            log.error("refusing skill %s: %s", resolved, exc)
