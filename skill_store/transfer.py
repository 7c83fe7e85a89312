"""Moving one version between a store and a plain folder (``gfc skills pull`` / ``push``).

A checkpoint folder holds ``model.safetensors`` and ``manifest.json``, exactly like a version
folder inside a store, and may itself be a local path or an fsspec URL.
"""

from __future__ import annotations

from pathlib import Path

from skill_store.backend import open_backend
from skill_store.checkpoint import load_checked
from skill_store.errors import PublishError
from skill_store.manifest import (
    MANIFEST_FILE,
    MAX_MANIFEST_BYTES,
    WEIGHTS_FILE,
    Manifest,
    parse_manifest,
)
from skill_store.store import MAX_WEIGHTS_BYTES


def read_checkpoint_folder(location: str | Path) -> tuple[Manifest, bytes]:
    """The manifest and weights in a folder, after every load-time check."""
    backend = open_backend(location)
    if not backend.exists(MANIFEST_FILE) or not backend.exists(WEIGHTS_FILE):
        raise PublishError(
            f"{location} is not a checkpoint folder: it needs {WEIGHTS_FILE} and {MANIFEST_FILE} "
            "(as written by 'gfc skills pull')"
        )
    manifest = parse_manifest(
        backend.read_bytes(MANIFEST_FILE, max_bytes=MAX_MANIFEST_BYTES), backend.path(MANIFEST_FILE)
    )
    limit = min(manifest.weights.size_bytes, MAX_WEIGHTS_BYTES)
    data = backend.read_bytes(WEIGHTS_FILE, max_bytes=limit)
    load_checked(manifest, data)
    return manifest, data


def write_checkpoint_folder(
    location: str | Path, manifest: Manifest, data: bytes, overwrite: bool = False
) -> None:
    """Write a version's files into a folder (the manifest last, as in a store)."""
    backend = open_backend(location)
    if not overwrite and (backend.exists(MANIFEST_FILE) or backend.exists(WEIGHTS_FILE)):
        raise PublishError(f"{location} already holds a checkpoint; choose an empty folder or pass --force")
    backend.fs.makedirs(backend.root, exist_ok=True)
    backend.replace_file(data, WEIGHTS_FILE)
    backend.replace_file(manifest.to_json_bytes(), MANIFEST_FILE)
