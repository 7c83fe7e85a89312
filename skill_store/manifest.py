"""The manifest: everything needed to rebuild, check and trace one stored skill version.

``manifest.json`` sits next to ``model.safetensors`` and is the only thing read before the
weights: it says what the model is (signature, token layout, normalisation, architecture), how
it was made (data hash, metrics, seed, command) and which bytes it belongs to (sha256, size).
It is plain JSON validated by pydantic, so reading it cannot run code.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from gfc.diffusion.denoiser import TokenLayout
from gfc.diffusion.network import DiTConfig
from skill_store.errors import ManifestError, PublishError
from skill_store.names import MAX_VERSION, validate_name

MANIFEST_FORMAT = "gfc.skill/1"
WEIGHTS_FILE = "model.safetensors"
MANIFEST_FILE = "manifest.json"
MAX_MANIFEST_BYTES = 4 * 1024 * 1024  # statistics for a few hundred dims fit in a few kB

TokenType = Literal["robot", "object", "action"]
WeightsDtype = Literal["float32", "bfloat16"]


class _Strict(BaseModel):
    # Unknown fields are refused: a typo in a hand-edited manifest must not pass silently.
    model_config = ConfigDict(extra="forbid", frozen=True)


class TokenEntry(_Strict):
    """One token of the skill model, in token order."""

    dim: int = Field(ge=1, le=4096)
    type: TokenType
    role: str | None = None  # the entity the token describes: robot, object, target, from, action
    phase: Literal["pre", "action", "effect"] | None = None


class Signature(_Strict):
    """What the model reads and writes: its tokens, their entities and frames."""

    skill: str | None = None  # the skill in gfc.skills.signatures, when the name is one
    tokens: list[TokenEntry] = Field(min_length=1, max_length=256)
    node_frame: str | None = None  # the frame robot and object tokens are expressed in
    action_frame: str | None = None

    @property
    def layout(self) -> TokenLayout:
        return TokenLayout(tuple(t.dim for t in self.tokens), tuple(t.type for t in self.tokens))


class Normalisation(_Strict):
    """Per-dimension statistics in raw units, flat in token order (``layout.total_dim`` each)."""

    mean: list[float]
    std: list[float]

    @field_validator("mean", "std")
    @classmethod
    def _finite(cls, values: list[float]) -> list[float]:
        if not all(math.isfinite(v) for v in values):
            raise ValueError("statistics must be finite numbers")
        return values

    @field_validator("std")
    @classmethod
    def _positive(cls, values: list[float]) -> list[float]:
        if not all(v > 0 for v in values):
            raise ValueError("standard deviations must be positive")
        return values


# Upper bounds on the architecture a manifest may ask for: far above any skill model, low enough
# that a hostile manifest cannot make the loader allocate without bound (``dropout``: 0..1).
_CONFIG_LIMITS = {
    "hidden": 4096,
    "depth": 64,
    "heads": 64,
    "mlp_ratio": 16,
    "max_token_dim": 4096,
    "freq_dim": 4096,
}


class Architecture(_Strict):
    """How to build the network: the one builder (``single_model``) and its config."""

    kind: Literal["dit-stack"] = "dit-stack"
    config: dict[str, int | float]

    @field_validator("config")
    @classmethod
    def _known_config(cls, config: dict[str, int | float]) -> dict[str, int | float]:
        defaults = DiTConfig().to_dict()
        unknown = sorted(set(config) - set(defaults))
        if unknown:
            raise ValueError(f"unknown DiTConfig fields {unknown}; fields are: {', '.join(defaults)}")
        for key, value in config.items():
            # Integer sizes must be integers: a float hidden size would only fail deep in torch.
            if isinstance(defaults[key], int) and not isinstance(value, int):
                raise ValueError(f"{key} must be an integer, not {value!r}")
            if not 0 <= value <= _CONFIG_LIMITS.get(key, 1):
                raise ValueError(f"{key} = {value} is outside 0..{_CONFIG_LIMITS.get(key, 1)}")
        return config

    @property
    def dit(self) -> DiTConfig:
        return DiTConfig.from_dict(dict(self.config))


class Training(_Strict):
    """How the weights were made, so a version can be traced and reproduced."""

    data_hash: str | None = Field(default=None, max_length=256)
    metrics: dict[str, float] = Field(default_factory=dict)
    seed: int | None = None
    command: str | None = Field(default=None, max_length=8192)
    notes: str | None = Field(default=None, max_length=8192)

    @field_validator("metrics")
    @classmethod
    def _finite_metrics(cls, metrics: dict[str, float]) -> dict[str, float]:
        # JSON has no NaN or infinity: such a metric would not read back.
        bad = sorted(k for k, v in metrics.items() if not math.isfinite(v))
        if bad:
            raise ValueError(f"metrics {bad} are not finite numbers; leave a metric out instead")
        return metrics


class WeightsInfo(_Strict):
    file: Literal["model.safetensors"] = "model.safetensors"
    sha256: str = Field(pattern=r"^[0-9a-f]{64}$")
    size_bytes: int = Field(ge=1)
    dtype: WeightsDtype  # of the network parameters; statistics and token types keep theirs


class Manifest(_Strict):
    format: Literal["gfc.skill/1"] = "gfc.skill/1"
    name: str
    version: int = Field(ge=1, le=MAX_VERSION)
    created_at: datetime
    signature: Signature
    normalisation: Normalisation
    architecture: Architecture
    training: Training = Field(default_factory=Training)
    weights: WeightsInfo

    @field_validator("name")
    @classmethod
    def _valid_name(cls, name: str) -> str:
        return validate_name(name)

    @field_validator("created_at")
    @classmethod
    def _utc(cls, created_at: datetime) -> datetime:
        if created_at.tzinfo is None:
            raise ValueError("created_at needs a time zone (UTC, e.g. 2026-01-01T00:00:00Z)")
        return created_at.astimezone(UTC)

    @model_validator(mode="after")
    def _consistent(self) -> Manifest:
        layout = self.signature.layout
        for field in ("mean", "std"):
            n = len(getattr(self.normalisation, field))
            if n != layout.total_dim:
                raise ValueError(
                    f"normalisation.{field} has {n} values; the token layout has {layout.total_dim} dims"
                )
        widest = self.architecture.dit.max_token_dim
        if max(layout.dims) > widest:
            raise ValueError(f"a token has {max(layout.dims)} dims; the network takes at most {widest}")
        return self

    @property
    def ref(self) -> str:
        return f"{self.name}@{self.version}"

    def to_json_bytes(self) -> bytes:
        return (self.model_dump_json(indent=2) + "\n").encode()


def parse_manifest(data: bytes, where: str) -> Manifest:
    """Parse and validate manifest bytes; ``where`` names the file in error messages."""
    if len(data) > MAX_MANIFEST_BYTES:
        raise ManifestError(
            f"{where} is {len(data)} bytes, over the {MAX_MANIFEST_BYTES}-byte limit for a manifest"
        )
    try:
        return Manifest.model_validate_json(data)
    except ValidationError as error:
        problems = "; ".join(f"{'.'.join(map(str, e['loc'])) or '(top)'}: {e['msg']}" for e in error.errors())
        raise ManifestError(f"{where} is not a valid skill manifest: {problems}") from None


def training_from_metadata(metadata: dict[str, Any]) -> Training:
    """The ``training`` section from a publisher's metadata dict (keys as in ``Training``)."""
    unknown = sorted(set(metadata) - set(Training.model_fields))
    if unknown:
        known = ", ".join(Training.model_fields)
        raise PublishError(f"unknown metadata keys {unknown}; the manifest records: {known}")
    try:
        return Training.model_validate(metadata)
    except ValidationError as error:
        raise PublishError(f"invalid metadata: {error}") from None


def utc_now() -> datetime:
    return datetime.now(UTC)
