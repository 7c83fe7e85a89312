"""Notice new versions and alias moves while the service runs, by polling.

Polling works the same on every backend (object stores have no portable change feed) and costs
one listing per skill per interval. ``StoreWatcher.poll()`` can be called by hand (tests, a
request handler); ``start()`` runs it on a daemon thread.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from typing import Literal

from skill_store.store import SkillState, SkillStore

logger = logging.getLogger(__name__)

ChangeKind = Literal["version_added", "alias_moved", "alias_removed"]


@dataclass(frozen=True)
class StoreChange:
    kind: ChangeKind
    name: str
    version: int | None = None  # the new version, or the alias's new target
    alias: str | None = None
    previous: int | None = None  # the alias's target before


StoreSnapshot = dict[str, SkillState]


def snapshot(store: SkillStore) -> StoreSnapshot:
    return {name: store.state(name) for name in store.skills()}


def diff(before: StoreSnapshot, after: StoreSnapshot) -> list[StoreChange]:
    """What changed between two snapshots (versions are never removed, so only additions)."""
    changes: list[StoreChange] = []
    empty = SkillState("", ())
    for name, now in sorted(after.items()):
        then = before.get(name, empty)
        changes += [
            StoreChange("version_added", name, version=v) for v in now.versions if v not in then.versions
        ]
        for alias, version in sorted(now.aliases.items()):
            if then.aliases.get(alias) != version:
                changes.append(StoreChange("alias_moved", name, version, alias, then.aliases.get(alias)))
        for alias in sorted(then.aliases.keys() - now.aliases.keys()):
            changes.append(StoreChange("alias_removed", name, alias=alias, previous=then.aliases[alias]))
    return changes


class StoreWatcher:
    """Polls a store and reports changes to ``on_change`` (and returns them from ``poll``).

    The first poll reports the whole store as added; pass ``initial=snapshot(store)`` to start
    from the current state instead.
    """

    def __init__(
        self,
        store: SkillStore,
        on_change: Callable[[list[StoreChange]], None] | None = None,
        interval_s: float = 5.0,
        initial: StoreSnapshot | None = None,
    ) -> None:
        self.store = store
        self.on_change = on_change
        self.interval_s = interval_s
        self.current: StoreSnapshot = initial if initial is not None else {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def poll(self) -> list[StoreChange]:
        latest = snapshot(self.store)
        changes = diff(self.current, latest)
        self.current = latest
        if changes and self.on_change is not None:
            self.on_change(changes)
        return changes

    def start(self) -> StoreWatcher:
        if self._thread is not None:
            raise RuntimeError("the watcher is already running")
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="skill-store-watcher", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                self.poll()
            except Exception:  # a store that is briefly unreachable must not kill the watcher
                logger.exception("polling the skill store %s failed; retrying", self.store.location)
            self._stop.wait(self.interval_s)

    def __enter__(self) -> StoreWatcher:
        return self.start()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()
