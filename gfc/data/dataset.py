"""Skill datasets on disk: safetensors shards plus one JSON index with a schema and hashes.

    DIR/dataset.json            {"format": "gfc-skill-dataset", "version": 1, "skill": ...,
                                 "layout": {...}, "shards": [{"file", "rows", "sha256",
                                 "attempts", "failures": {type: n}}], "meta": {...}}
    DIR/shard-00000.safetensors {"x": (rows, D) float32}: (pre nodes, action, effect nodes)
                                 in the acting robot's base frame, flattened in token order

Shards are written to a temporary name and renamed, and the index is rewritten (also atomically)
after each one, so an interrupted collection resumes from the last complete shard and a reader
never sees half a shard. Every shard's sha256 is checked on load. No pickle: safetensors and JSON.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch
from safetensors.torch import load as load_tensors
from safetensors.torch import save as save_tensors

from gfc.diffusion.denoiser import TokenLayout

FORMAT = "gfc-skill-dataset"
VERSION = 1
INDEX = "dataset.json"


class DatasetError(ValueError):
    """A dataset that is missing, malformed, or fails its checks."""


@dataclass
class Shard:
    file: str
    rows: int
    sha256: str
    attempts: int  # executions that produced this shard
    failures: dict[str, int] = field(default_factory=dict)  # failure type (or "setup") -> count

    @property
    def success_rate(self) -> float:
        """Successes over attempts whose set-up worked (a two-handed success gives two rows, so
        this is not rows / attempts)."""
        tried = self.attempts - self.failures.get("setup", 0)
        failed = sum(v for k, v in self.failures.items() if k != "setup")
        return (tried - failed) / tried if tried else 0.0


@dataclass
class DatasetIndex:
    skill: str
    layout: TokenLayout
    shards: list[Shard] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def rows(self) -> int:
        return sum(s.rows for s in self.shards)

    @property
    def content_hash(self) -> str:
        """One hash for the whole dataset: the shards' hashes and the layout, in order."""
        digest = hashlib.sha256(json.dumps({"skill": self.skill, "dims": self.layout.dims}).encode())
        for shard in self.shards:
            digest.update(shard.sha256.encode())
        return digest.hexdigest()

    def to_json(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "version": VERSION,
            "skill": self.skill,
            "layout": {"dims": list(self.layout.dims), "types": list(self.layout.types)},
            "shards": [s.__dict__ for s in self.shards],
            "content_hash": self.content_hash,
            "meta": self.meta,
        }

    @staticmethod
    def from_json(data: dict[str, Any], where: str) -> DatasetIndex:
        if data.get("format") != FORMAT or data.get("version") != VERSION:
            raise DatasetError(f"{where}: not a {FORMAT} v{VERSION} index")
        try:
            layout = TokenLayout(tuple(data["layout"]["dims"]), tuple(data["layout"]["types"]))
            shards = [Shard(**s) for s in data["shards"]]
            return DatasetIndex(str(data["skill"]), layout, shards, dict(data.get("meta", {})))
        except (KeyError, TypeError, ValueError) as exc:
            raise DatasetError(f"{where}: malformed index ({exc})") from None


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_bytes(data)
    with open(tmp, "rb") as handle:
        os.fsync(handle.fileno())
    tmp.replace(path)


class DatasetWriter:
    """Appends shards to a dataset directory (creating it, or resuming an existing one)."""

    def __init__(
        self, root: str | Path, skill: str, layout: TokenLayout, meta: dict[str, Any] | None = None
    ) -> None:
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        index_path = self.root / INDEX
        if index_path.exists():
            self.index = read_index(self.root)
            if self.index.skill != skill or self.index.layout != layout:
                raise DatasetError(
                    f"{self.root} holds {self.index.skill} {self.index.layout.dims}, not {skill} {layout.dims}; "
                    "use another directory"
                )
        else:
            self.index = DatasetIndex(skill, layout, meta=dict(meta or {}))

    @property
    def next_shard(self) -> int:
        return len(self.index.shards)

    def add_shard(self, rows: torch.Tensor, attempts: int, failures: dict[str, int]) -> Shard:
        if rows.ndim != 2 or rows.shape[1] != self.index.layout.total_dim:
            raise DatasetError(
                f"a shard must be (rows, {self.index.layout.total_dim}), got {tuple(rows.shape)}"
            )
        data = save_tensors({"x": rows.to(torch.float32).contiguous()})
        name = f"shard-{self.next_shard:05d}.safetensors"
        _atomic_write(self.root / name, data)
        shard = Shard(name, int(rows.shape[0]), hashlib.sha256(data).hexdigest(), attempts, dict(failures))
        self.index.shards.append(shard)
        _atomic_write(self.root / INDEX, json.dumps(self.index.to_json(), indent=2).encode())
        return shard


def read_index(root: str | Path) -> DatasetIndex:
    path = Path(root) / INDEX
    if not path.is_file():
        raise DatasetError(f"{root} is not a dataset (no {INDEX}); collect one with `gfc collect`")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise DatasetError(f"{path}: not JSON ({exc.msg})") from None
    return DatasetIndex.from_json(data, str(path))


def load_dataset(root: str | Path) -> tuple[torch.Tensor, DatasetIndex]:
    """All rows (N, D) float32, after checking every shard's hash and shape."""
    index = read_index(root)
    parts = []
    for shard in index.shards:
        data = (Path(root) / shard.file).read_bytes()
        if hashlib.sha256(data).hexdigest() != shard.sha256:
            raise DatasetError(
                f"{root}/{shard.file} does not match its sha256 in {INDEX}: re-collect that shard"
            )
        x = load_tensors(data)["x"]
        if tuple(x.shape) != (shard.rows, index.layout.total_dim):
            raise DatasetError(
                f"{root}/{shard.file} has shape {tuple(x.shape)}, the index says ({shard.rows}, ...)"
            )
        parts.append(x)
    if not parts:
        raise DatasetError(f"{root} has no shards yet")
    return torch.cat(parts), index
