"""Aliases (``latest``, ``production``, any name) and the audit log of every change to them.

An alias is one small file, ``<skill>/aliases/<alias>.json``, replaced atomically on each move,
so a reader sees the old target or the new one. The audit log is append-only and made of one
immutable file per event, ``<skill>/audit/<UTC time>-<random>.json``: object stores cannot
append to a file, but every backend can add a new one, and concurrent writers never clash.
The entry is written *before* the alias moves, so no move can happen without its entry.
"""

from __future__ import annotations

import getpass
import socket
import uuid
from datetime import datetime
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from skill_store.backend import StoreBackend
from skill_store.errors import InvalidNameError, ManifestError
from skill_store.manifest import utc_now
from skill_store.names import validate_alias

ALIASES_DIR = "aliases"
AUDIT_DIR = "audit"
MAX_RECORD_BYTES = 64 * 1024

AuditEvent = Literal["published", "alias_moved", "alias_removed", "pruned"]


class AliasRecord(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    version: int = Field(ge=1)
    moved_at: datetime
    actor: str


class AuditEntry(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    at: datetime
    event: AuditEvent
    name: str
    version: int | None = None  # the version published, or the alias's new target
    alias: str | None = None
    previous: int | None = None  # the alias's target before the move
    actor: str
    reason: str | None = Field(default=None, max_length=2000)


def current_actor() -> str:
    """Who is acting, as ``user@host``, for the audit log."""
    try:
        user = getpass.getuser()
    except (OSError, KeyError):  # no login name in some containers
        user = "unknown"
    return f"{user}@{socket.gethostname()}"


def read_aliases(backend: StoreBackend, name: str) -> dict[str, int]:
    """Every alias of a skill and the version it points at."""
    out: dict[str, int] = {}
    for file in backend.list_names(name, ALIASES_DIR):
        alias, dot, ext = file.rpartition(".")
        if ext != "json" or not dot or not is_alias(alias):
            continue  # temp files of an alias being replaced, stray files
        record = read_alias(backend, name, alias)
        if record is not None:
            out[alias] = record.version
    return out


def is_alias(text: str) -> bool:
    try:
        validate_alias(text)
    except InvalidNameError:
        return False
    return True


def read_alias(backend: StoreBackend, name: str, alias: str) -> AliasRecord | None:
    path = (name, ALIASES_DIR, f"{validate_alias(alias)}.json")
    try:
        data = backend.read_bytes(*path, max_bytes=MAX_RECORD_BYTES)
    except FileNotFoundError:
        return None
    try:
        return AliasRecord.model_validate_json(data)
    except ValidationError as error:
        raise ManifestError(
            f"alias file {backend.path(*path)} is unreadable ({error}); move the alias again"
        ) from None


def append_audit(backend: StoreBackend, entry: AuditEntry) -> None:
    stamp = entry.at.strftime("%Y%m%dT%H%M%S.%fZ")
    # Sorting file names sorts entries by time; the random part keeps simultaneous ones apart,
    # so each entry has a file of its own, written whole (readers never see half an entry).
    file = f"{stamp}-{uuid.uuid4().hex[:12]}.json"
    backend.replace_file(entry.model_dump_json().encode(), entry.name, AUDIT_DIR, file)


def read_audit(backend: StoreBackend, name: str) -> list[AuditEntry]:
    """A skill's audit log, oldest first."""
    entries = []
    for file in backend.list_names(name, AUDIT_DIR):
        if not file.endswith(".json"):
            continue
        data = backend.read_bytes(name, AUDIT_DIR, file, max_bytes=MAX_RECORD_BYTES)
        try:
            entries.append(AuditEntry.model_validate_json(data))
        except ValidationError as error:
            where = backend.path(name, AUDIT_DIR, file)
            raise ManifestError(f"audit entry {where} is unreadable ({error})") from None
    return entries


def move_alias(
    backend: StoreBackend, name: str, alias: str, version: int, actor: str, reason: str | None = None
) -> AuditEntry:
    """Point ``alias`` at ``version`` (which the caller has checked exists), logging the move."""
    validate_alias(alias)
    previous = read_alias(backend, name, alias)
    now = utc_now()
    entry = AuditEntry(
        at=now,
        event="alias_moved",
        name=name,
        alias=alias,
        version=version,
        previous=previous.version if previous else None,
        actor=actor,
        reason=reason,
    )
    append_audit(backend, entry)
    record = AliasRecord(version=version, moved_at=now, actor=actor)
    backend.replace_file(record.model_dump_json().encode(), name, ALIASES_DIR, f"{alias}.json")
    return entry


def remove_alias(
    backend: StoreBackend, name: str, alias: str, actor: str, reason: str | None = None
) -> AuditEntry | None:
    """Delete an alias, logging it; None when there was no such alias."""
    previous = read_alias(backend, name, alias)
    if previous is None:
        return None
    entry = AuditEntry(
        at=utc_now(),
        event="alias_removed",
        name=name,
        alias=alias,
        previous=previous.version,
        actor=actor,
        reason=reason,
    )
    append_audit(backend, entry)
    backend.remove_file(name, ALIASES_DIR, f"{alias}.json")
    return entry
