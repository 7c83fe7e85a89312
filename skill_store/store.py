"""The skill store: publish, list, resolve, verify and load versioned skill models.

Layout under the store's root (a folder or an fsspec URL)::

    <skill>/<version>/model.safetensors   weights (safetensors, never pickle)
    <skill>/<version>/manifest.json       written last: a version exists once this does
    <skill>/aliases/<alias>.json          {"version": 3, ...}, replaced atomically
    <skill>/audit/<time>-<id>.json        one immutable entry per publish and alias change
    <skill>/.claims/<version>             exclusive-create claims that allocate version numbers

Versions are immutable: a number is claimed exclusively before anything is written, the
version appears atomically (see ``skill_store.backend``), and nothing rewrites it afterwards.
Nothing is cached here: every call reads the store, so new versions and alias moves are seen
by the next call. Callers that want fewer reads keep a ``SkillState`` (``StoreLibrary`` does).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from gfc.diffusion.denoiser import Precision, StackedDenoiser
from skill_store.aliases import (
    AuditEntry,
    append_audit,
    current_actor,
    move_alias,
    read_aliases,
    read_audit,
    remove_alias,
)
from skill_store.backend import StoreBackend, open_backend
from skill_store.checkpoint import load_checked, serialise, sha256_hex
from skill_store.errors import (
    IntegrityError,
    ManifestError,
    PublishError,
    SkillNotFoundError,
    SkillStoreError,
)
from skill_store.manifest import (
    MANIFEST_FILE,
    MAX_MANIFEST_BYTES,
    WEIGHTS_FILE,
    Architecture,
    Manifest,
    Normalisation,
    WeightsInfo,
    parse_manifest,
    training_from_metadata,
    utc_now,
)
from skill_store.names import (
    LATEST,
    MAX_VERSION,
    SkillRef,
    is_version_text,
    parse_ref,
    validate_alias,
    validate_name,
)
from skill_store.signature import signature_for

CLAIMS_DIR = ".claims"
MAX_WEIGHTS_BYTES = 2 * 1024**3  # far above any skill model; refuses a runaway file before reading it
MAX_CLAIM_ATTEMPTS = 1000

DEFAULT_LIBRARY = Path(__file__).parent / "library"


@dataclass(frozen=True)
class ResolvedRef:
    name: str
    version: int

    def __str__(self) -> str:
        return f"{self.name}@{self.version}"


@dataclass(frozen=True)
class SkillState:
    """A skill's published versions and aliases at one moment; resolves references offline."""

    name: str
    versions: tuple[int, ...]  # ascending
    aliases: dict[str, int] = field(default_factory=dict)

    def resolve(self, ref: SkillRef, where: str = "the store") -> ResolvedRef:
        if ref.name != self.name:
            raise ValueError(f"{ref} is not a reference to {self.name}")
        if not self.versions:
            raise SkillNotFoundError(f"{where} has no published version of {self.name}")
        if ref.version is not None:
            if ref.version not in self.versions:
                raise SkillNotFoundError(
                    f"{self.name} has no version {ref.version} in {where} (published: {_short(self.versions)})"
                )
            return ResolvedRef(self.name, ref.version)
        alias = ref.alias or LATEST
        if alias in self.aliases:
            return ResolvedRef(self.name, self.aliases[alias])
        if alias == LATEST:  # no explicit 'latest': the highest version, as in Triton's policy
            return ResolvedRef(self.name, self.versions[-1])
        have = ", ".join(sorted(self.aliases)) or "none"
        raise SkillNotFoundError(
            f"{self.name} has no alias {alias!r} in {where} (aliases: {have}); "
            f"set it with: gfc skills alias {self.name} {alias} VERSION"
        )


@dataclass(frozen=True)
class VerifyResult:
    ref: str
    ok: bool
    problem: str | None = None


class SkillStore:
    """Versioned skill models under a folder or fsspec URL (default: the packaged library)."""

    def __init__(self, location: str | Path = DEFAULT_LIBRARY) -> None:
        self.backend: StoreBackend = open_backend(location)
        self.location = str(location)

    def __repr__(self) -> str:
        return f"SkillStore({self.location!r})"

    # -- reading ------------------------------------------------------------------------------

    def skills(self) -> list[str]:
        """Names of the skills with at least one published version."""
        names = []
        for entry in self.backend.list_names():
            try:
                validate_name(entry)
            except SkillStoreError:
                continue  # stray files and folders are not skills
            if self.versions(entry):
                names.append(entry)
        return names

    def versions(self, name: str) -> tuple[int, ...]:
        """Published versions of a skill, ascending (those whose manifest exists)."""
        validate_name(name)
        numbers = sorted(int(e) for e in self.backend.list_names(name) if is_version_text(e))
        return tuple(v for v in numbers if self.backend.exists(name, str(v), MANIFEST_FILE))

    def aliases(self, name: str) -> dict[str, int]:
        return read_aliases(self.backend, validate_name(name))

    def state(self, name: str) -> SkillState:
        return SkillState(name, self.versions(name), self.aliases(name))

    def resolve(self, ref: str | SkillRef | ResolvedRef) -> ResolvedRef:
        """``pick.hammer`` / ``pick.hammer@3`` / ``pick.hammer@production`` -> ``pick.hammer@3``.

        A ``ResolvedRef`` is already resolved and returned as it is (versions are immutable)."""
        if isinstance(ref, ResolvedRef):
            return ref
        parsed = parse_ref(ref) if isinstance(ref, str) else ref
        return self.state(parsed.name).resolve(parsed, where=self.location)

    def manifest(self, ref: str | SkillRef | ResolvedRef) -> Manifest:
        resolved = self.resolve(ref)
        return self._read_manifest(resolved)

    def weights_bytes(self, ref: str | SkillRef | ResolvedRef) -> tuple[Manifest, bytes]:
        """The manifest and the raw weights of a version, checked (sha256 and structure)."""
        resolved = self.resolve(ref)
        manifest = self._read_manifest(resolved)
        data = self._read_weights(resolved, manifest)
        load_checked(manifest, data)
        return manifest, data

    def load(
        self, ref: str | SkillRef | ResolvedRef, precision: Precision | Literal["stored"] = "float32"
    ) -> StackedDenoiser:
        """A ready-to-call denoiser (eval mode), after every integrity check.

        ``precision`` is what the network computes in: float32 by default, whatever the weights
        are stored as (bfloat16 values are exact in float32, and bfloat16 matmuls are 90 times
        slower than float32 on a CPU without native bfloat16, e.g. AVX2 only); ``"stored"``
        keeps the stored dtype."""
        resolved = self.resolve(ref)
        manifest = self._read_manifest(resolved)
        model = load_checked(manifest, self._read_weights(resolved, manifest))
        if precision != "stored" and model.precision != precision:
            model = model.with_precision(precision)
        return model

    def audit_log(self, name: str) -> list[AuditEntry]:
        return read_audit(self.backend, validate_name(name))

    def verify(self, refs: Iterable[str] | None = None) -> list[VerifyResult]:
        """Check versions (default: every version of every skill); one result per version."""
        targets: list[ResolvedRef] = []
        if refs is None:
            targets = [ResolvedRef(n, v) for n in self.skills() for v in self.versions(n)]
        else:
            for ref in refs:
                parsed = parse_ref(ref)
                if parsed.version is None and parsed.alias is None:  # a bare name: all versions
                    versions = self.versions(parsed.name)
                    if not versions:
                        raise SkillNotFoundError(f"{self.location} has no published version of {parsed.name}")
                    targets += [ResolvedRef(parsed.name, v) for v in versions]
                else:
                    targets.append(self.resolve(parsed))
        results = []
        for target in targets:
            try:
                manifest = self._read_manifest(target)
                load_checked(manifest, self._read_weights(target, manifest))
            except (IntegrityError, OSError) as error:
                results.append(VerifyResult(str(target), False, str(error)))
            else:
                results.append(VerifyResult(str(target), True))
        return results

    def _read_manifest(self, ref: ResolvedRef) -> Manifest:
        where = self.backend.path(ref.name, str(ref.version), MANIFEST_FILE)
        try:
            data = self.backend.read_bytes(
                ref.name, str(ref.version), MANIFEST_FILE, max_bytes=MAX_MANIFEST_BYTES
            )
        except FileNotFoundError:
            raise SkillNotFoundError(f"{ref} is not published in {self.location}") from None
        manifest = parse_manifest(data, where)
        if (manifest.name, manifest.version) != (ref.name, ref.version):
            raise IntegrityError(
                f"{where} describes {manifest.ref}, not {ref}: a version folder was copied or renamed "
                "by hand; publish it with 'gfc skills push' instead"
            )
        return manifest

    def _read_weights(self, ref: ResolvedRef, manifest: Manifest) -> bytes:
        limit = min(manifest.weights.size_bytes, MAX_WEIGHTS_BYTES)
        try:
            return self.backend.read_bytes(ref.name, str(ref.version), WEIGHTS_FILE, max_bytes=limit)
        except FileNotFoundError:
            raise IntegrityError(f"{ref} has a manifest but no {WEIGHTS_FILE}; publish it again") from None

    # -- writing ------------------------------------------------------------------------------

    def publish(
        self,
        name: str,
        model: StackedDenoiser,
        metadata: dict[str, Any] | None = None,
        aliases: Sequence[str] = (),
    ) -> int:
        """Store ``model`` (a stack of one) as the next version of ``name``; returns the version.

        ``metadata`` fills the manifest's training record: ``data_hash``, ``metrics``, ``seed``,
        ``command``, ``notes``. ``aliases`` are moved to the new version afterwards (each move
        logged); by default none moves, and a bare ``name`` resolves to the highest version
        until ``latest`` is set explicitly.
        """
        validate_name(name)
        data, weights_dtype = serialise(model)
        layout = model.layouts[0]
        manifest = Manifest(
            name=name,
            version=1,  # placeholder until a number is claimed
            created_at=utc_now(),
            signature=signature_for(name, layout),
            normalisation=Normalisation(
                mean=layout.unpad(model.mean[0]).tolist(), std=layout.unpad(model.std[0]).tolist()
            ),
            architecture=Architecture(config=model.config.to_dict()),
            training=training_from_metadata(metadata or {}),
            weights=WeightsInfo(sha256=sha256_hex(data), size_bytes=len(data), dtype=weights_dtype),
        )
        return self.publish_checkpoint(manifest, data, aliases)

    def publish_checkpoint(self, manifest: Manifest, data: bytes, aliases: Sequence[str] = ()) -> int:
        """Store weights with their manifest as the next version of ``manifest.name`` (the
        manifest's version number is replaced by the one allocated). Refuses a pair that fails
        the load-time checks, so nothing unloadable is ever published."""
        for alias in aliases:
            validate_alias(alias)  # before publishing: a bad alias must not leave a version behind
        load_checked(manifest, data)
        try:  # what is published must read back (before a version number is spent on it)
            parse_manifest(manifest.to_json_bytes(), f"the manifest for {manifest.name}")
        except ManifestError as error:
            raise PublishError(str(error)) from None
        name = manifest.name
        version = self._claim_next_version(name)
        # created_at is when this store got the version (a pushed checkpoint keeps its training record).
        manifest = manifest.model_copy(update={"version": version, "created_at": utc_now()})
        files = {WEIGHTS_FILE: data, MANIFEST_FILE: manifest.to_json_bytes()}
        self.backend.publish_folder(files, MANIFEST_FILE, name, str(version))
        actor = current_actor()
        append_audit(
            self.backend, AuditEntry(at=utc_now(), event="published", name=name, version=version, actor=actor)
        )
        for alias in aliases:
            move_alias(self.backend, name, alias, version, actor)
        return version

    def set_alias(self, ref: str, alias: str, reason: str | None = None) -> AuditEntry:
        """Point ``alias`` at the version ``ref`` resolves to (``pick.hammer@3``), logging it."""
        target = self.resolve(ref)
        return move_alias(self.backend, target.name, alias, target.version, current_actor(), reason)

    def remove_alias(self, name: str, alias: str, reason: str | None = None) -> AuditEntry:
        entry = remove_alias(self.backend, validate_name(name), alias, current_actor(), reason)
        if entry is None:
            raise SkillNotFoundError(f"{name} has no alias {alias!r} in {self.location}")
        return entry

    def prunable(self, name: str, keep: int = 1) -> list[int]:
        """Versions ``prune`` would remove: all but the newest ``keep``, except aliased ones."""
        if keep < 1:
            raise ValueError(f"keep must be at least 1 (the latest version always stays), got {keep}")
        versions = self.versions(name)
        aliased = set(self.aliases(name).values())
        return [v for v in versions[:-keep] if v not in aliased]

    def prune(self, name: str, keep: int = 1, reason: str | None = None) -> list[int]:
        """Remove superseded versions of a skill (``prunable``), logging each in the audit log.

        The manifest goes first, so a version disappears at once for readers; its number stays
        claimed and is never handed out again. Returns the versions removed."""
        removed = []
        for version in self.prunable(validate_name(name), keep):
            entry = AuditEntry(
                at=utc_now(), event="pruned", name=name, version=version, actor=current_actor(), reason=reason
            )
            append_audit(self.backend, entry)
            self.backend.remove_file(name, str(version), MANIFEST_FILE)
            for file in self.backend.list_names(name, str(version)):
                self.backend.remove_file(name, str(version), file)
            self.backend.remove_folder(name, str(version))
            removed.append(version)
        return removed

    def _claim_next_version(self, name: str) -> int:
        """Allocate a version number no other publisher can get: exclusive-create a claim file.

        A publisher that dies after claiming leaves a gap in the numbers, never a duplicate."""
        taken = [int(e) for e in self.backend.list_names(name, CLAIMS_DIR) if is_version_text(e)]
        # Every numbered folder counts, published or not: a half-copied one must not be merged into.
        taken += [int(e) for e in self.backend.list_names(name) if is_version_text(e)]
        candidate = max(taken, default=0) + 1
        claim = json.dumps({"actor": current_actor(), "at": utc_now().isoformat()}).encode()
        for _ in range(MAX_CLAIM_ATTEMPTS):
            if candidate > MAX_VERSION:
                break
            if self.backend.create_exclusive(claim, name, CLAIMS_DIR, str(candidate)):
                return candidate
            candidate += 1
        raise PublishError(f"could not allocate a version number for {name} in {self.location}")


def _short(versions: Sequence[int]) -> str:
    shown = ", ".join(map(str, versions[-10:]))
    return ("..., " if len(versions) > 10 else "") + shown
