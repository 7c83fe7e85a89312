"""Where the bytes live: a local folder, or any fsspec filesystem (``s3://``, ``gs://``,
``memory://``), behind the few operations the store needs.

The store's guarantees rest on three primitives, and each backend provides them its own way:

============================  =================================  =================================
primitive                     local folder                       object store (fsspec URL)
============================  =================================  =================================
publish a version atomically  write a staging folder next to     write the weights, then the
                              the versions, fsync, ``os.rename``  manifest *last*: a version
                              it to ``<version>/``               without a manifest is invisible
create a file exclusively     ``O_CREAT | O_EXCL``               ``pipe_file(mode="create")``
(version claims)                                                 (S3 ``If-None-Match: *``, GCS
                                                                 ``ifGenerationMatch=0``); plus a
                                                                 process lock for ``memory://``
replace a small file          temp file + ``os.replace``         one PUT (objects appear whole)
atomically (aliases)
============================  =================================  =================================

Readers on every backend treat a version as published only when its ``manifest.json`` exists,
so a half-copied folder (someone ``cp -r``-ing into the store by hand) is never picked up either.
"""

from __future__ import annotations

import contextlib
import os
import posixpath
import threading
import uuid
from pathlib import Path
from typing import Any

import fsspec
from fsspec.implementations.local import LocalFileSystem

from skill_store.errors import IntegrityError


class StoreBackend:
    """Byte-level access to the store under ``root``; paths are '/'-joined and relative to it."""

    def __init__(self, fs: Any, root: str, location: str) -> None:
        self.fs = fs
        self.root = root.rstrip("/") or "/"
        self.location = location  # as the user gave it, for messages

    def path(self, *parts: str) -> str:
        return posixpath.join(self.root, *parts)

    def exists(self, *parts: str) -> bool:
        return bool(self.fs.exists(self.path(*parts)))

    def list_names(self, *parts: str) -> list[str]:
        """Names of the entries directly under a folder; empty when it does not exist."""
        try:
            entries = self.fs.ls(self.path(*parts), detail=False)
        except (FileNotFoundError, NotADirectoryError):
            return []
        return sorted(posixpath.basename(str(e).rstrip("/")) for e in entries)

    def read_bytes(self, *parts: str, max_bytes: int) -> bytes:
        """Read a whole file, refusing files larger than ``max_bytes`` before reading them."""
        path = self.path(*parts)
        size = int(self.fs.size(path))
        if size > max_bytes:
            raise IntegrityError(f"{path} is {size} bytes, over the {max_bytes}-byte limit for this file")
        data = self.fs.cat_file(path)
        return bytes(data)

    def create_exclusive(self, data: bytes, *parts: str) -> bool:
        """Create a file only if it does not exist; False when it does (someone else won)."""
        path = self.path(*parts)
        self.fs.makedirs(posixpath.dirname(path), exist_ok=True)
        try:
            with _PROCESS_LOCK:
                self.fs.pipe_file(path, data, mode="create")
        except FileExistsError:
            return False
        return True

    def replace_file(self, data: bytes, *parts: str) -> None:
        """Write a small file so that readers see the old or the new content, never a mix."""
        path = self.path(*parts)
        self.fs.makedirs(posixpath.dirname(path), exist_ok=True)
        self.fs.pipe_file(path, data)

    def remove_file(self, *parts: str) -> None:
        self.fs.rm_file(self.path(*parts))

    def remove_folder(self, *parts: str) -> None:
        """Remove an empty folder (its files removed first, by the caller). Object stores have
        no folders of their own: one goes with its last file, so a missing one is fine."""
        with contextlib.suppress(FileNotFoundError):
            self.fs.rmdir(self.path(*parts))

    def publish_folder(self, files: dict[str, bytes], commit_file: str, *parts: str) -> None:
        """Make a folder with these files appear; ``commit_file`` is written last and marks it done.

        The folder must not exist yet (the caller holds the version's claim)."""
        folder = self.path(*parts)
        for name, data in files.items():
            if name != commit_file:
                self.fs.pipe_file(posixpath.join(folder, name), data)
        self.fs.pipe_file(posixpath.join(folder, commit_file), files[commit_file])


class LocalBackend(StoreBackend):
    """A folder on a local (or POSIX network) filesystem: renames are atomic, so use them."""

    def create_exclusive(self, data: bytes, *parts: str) -> bool:
        path = self.path(*parts)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            return False
        with os.fdopen(fd, "wb") as file:
            file.write(data)
        return True

    def replace_file(self, data: bytes, *parts: str) -> None:
        path = self.path(*parts)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        temp = f"{path}.{uuid.uuid4().hex}.tmp"
        _write_durably(temp, data)
        os.replace(temp, path)

    def publish_folder(self, files: dict[str, bytes], commit_file: str, *parts: str) -> None:
        folder = self.path(*parts)
        parent = os.path.dirname(folder)
        # Staging lives beside the versions (same filesystem, so the rename is atomic) under a
        # dot-name that listings skip.
        staging = os.path.join(parent, ".staging", uuid.uuid4().hex)
        os.makedirs(staging)
        for name, data in files.items():
            _write_durably(os.path.join(staging, name), data)
        _fsync_dir(staging)
        # The whole version appears at once; it fails if the target exists rather than merging.
        os.rename(staging, folder)
        _fsync_dir(parent)


def _write_durably(path: str, data: bytes) -> None:
    with open(path, "wb") as file:
        file.write(data)
        file.flush()
        os.fsync(file.fileno())


def _fsync_dir(path: str) -> None:
    # A rename is durable only once its directory is synced (no-op where unsupported).
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# fsspec's in-memory filesystem checks and creates in two steps; within one process (the only
# place a memory:// store exists) this lock makes exclusive creation atomic.
_PROCESS_LOCK = threading.Lock()


def open_backend(location: str | Path) -> StoreBackend:
    """The backend for a folder path or an fsspec URL (``memory://store``, ``s3://bucket/skills``)."""
    text = str(location)
    fs, root = fsspec.core.url_to_fs(text)
    if isinstance(fs, LocalFileSystem):
        return LocalBackend(fs, os.path.abspath(root), text)
    return StoreBackend(fs, root, text)
