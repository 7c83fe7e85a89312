"""The planner's view of the store: ``SkillLibrary.bank(refs)`` over stored, versioned models.

References are resolved against each skill's state (versions and aliases), re-read when older
than ``state_ttl_s``: a new version or an alias move reaches the planner within that time,
without a restart, while a busy service does not list the store on every request. Loaded models
are cached by resolved ``name@version`` (immutable, so the cache never goes stale); banks are
cached by the resolved tuple, so a moved alias yields a new bank.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict

from gfc.diffusion.denoiser import Precision, StackedDenoiser
from gfc.planner.library import Bank, stack_models
from gfc.skills.signatures import SKILLS
from skill_store.errors import SkillStoreError
from skill_store.manifest import Signature
from skill_store.names import parse_ref
from skill_store.store import ResolvedRef, SkillState, SkillStore


class StoreLibrary:
    """Implements ``gfc.planner.library.SkillLibrary`` on a ``SkillStore``."""

    def __init__(
        self,
        store: SkillStore,
        cache_size: int = 64,
        precision: Precision = "float32",
        state_ttl_s: float = 2.0,
    ) -> None:
        self.store = store
        self.precision = precision
        self.state_ttl_s = state_ttl_s
        self._cache_size = cache_size
        self._states: dict[str, tuple[float, SkillState]] = {}
        self._models: OrderedDict[ResolvedRef, StackedDenoiser] = OrderedDict()
        self._banks: OrderedDict[tuple[ResolvedRef, ...], StackedDenoiser] = OrderedDict()
        self._lock = threading.Lock()  # the service calls bank() from several threads

    def resolve(self, ref: str) -> ResolvedRef:
        parsed = parse_ref(ref)
        with self._lock:
            cached = self._states.get(parsed.name)
        if cached is None or time.monotonic() - cached[0] > self.state_ttl_s:
            cached = (time.monotonic(), self.store.state(parsed.name))
            with self._lock:
                self._states[parsed.name] = cached
        return cached[1].resolve(parsed, where=self.store.location)

    def refresh(self) -> None:
        """Forget cached skill states: the next call sees the store as it is now."""
        with self._lock:
            self._states.clear()

    def unload(self, name: str, version: int | None = None) -> int:
        """Drop cached models of ``name`` (one version, or all) and every bank built from them;
        returns how many models were dropped. The next request loads (and checks) afresh."""

        def matches(ref: ResolvedRef) -> bool:
            return ref.name == name and (version is None or ref.version == version)

        with self._lock:
            dropped = [ref for ref in self._models if matches(ref)]
            for ref in dropped:
                del self._models[ref]
            for key in [k for k in self._banks if any(matches(r) for r in k)]:
                del self._banks[key]
        return len(dropped)

    def model(self, resolved: ResolvedRef) -> StackedDenoiser:
        with self._lock:
            model = self._models.get(resolved)
            if model is not None:
                self._models.move_to_end(resolved)
                return model
        check_action_frame(self.store.manifest(resolved).signature, str(resolved))
        model = self.store.load(resolved)
        with self._lock:
            self._models[resolved] = model
            _trim(self._models, self._cache_size)
        return model

    def bank(self, refs: list[str]) -> Bank:
        resolved = tuple(self.resolve(ref) for ref in refs)
        with self._lock:
            stacked = self._banks.get(resolved)
            if stacked is not None:
                self._banks.move_to_end(resolved)
        if stacked is None:
            stacked = stack_models([self.model(r) for r in resolved], self.precision)
            with self._lock:
                self._banks[resolved] = stacked
                _trim(self._banks, self._cache_size)
        return Bank(stacked, {ref: str(r) for ref, r in zip(refs, resolved, strict=True)})


class IncompatibleModelError(SkillStoreError):
    """A stored model whose actions mean something else than what this code executes."""


def check_action_frame(signature: Signature, where: str) -> None:
    """Refuse a model trained when its skill's action was expressed in another frame: its samples
    would be executed as if they meant something else (push and pull moved from the target's
    frame to its approach frame in session 6)."""
    spec = SKILLS.get(signature.skill or "")
    if spec is None or signature.action_frame is None or signature.action_frame == spec.action_frame:
        return
    raise IncompatibleModelError(
        f"{where} was trained with actions as {signature.action_frame!r}, but this code executes "
        f"{spec.name} actions as {spec.action_frame!r}; retrain it (gfc library build --only "
        f"{where.split('@')[0]}) or use a version trained by this code"
    )


def _trim(
    cache: OrderedDict[ResolvedRef, StackedDenoiser] | OrderedDict[tuple[ResolvedRef, ...], StackedDenoiser],
    size: int,
) -> None:
    while len(cache) > size:
        cache.popitem(last=False)
