"""Weights to bytes and back, with every check done before a tensor is trusted.

Weights are safetensors (a JSON header and raw little-endian buffers): reading them cannot run
code, unlike pickle-based ``torch.load``. Loading checks, in order:

1. the size and sha256 of the bytes against the manifest (corruption, tampering);
2. the safetensors header, parsed here without loading anything, against the tensor names,
   shapes and dtypes that the manifest's architecture implies (a manifest from another model);
3. the stored statistics and token types against the manifest's (a manifest edited by hand);

and only then builds the model from the manifest and loads the tensors with ``strict=True``.
"""

from __future__ import annotations

import hashlib
import json
import struct
from dataclasses import dataclass

import safetensors.torch
import torch

from gfc.diffusion.denoiser import StackedDenoiser, single_model
from gfc.diffusion.network import TOKEN_TYPES
from skill_store.errors import IntegrityError, PublishError
from skill_store.manifest import Manifest, WeightsDtype

MAX_HEADER_BYTES = 16 * 1024 * 1024  # safetensors' own limit is 100 MB; ours are a few kB

_SAFETENSORS_DTYPES: dict[torch.dtype, str] = {
    torch.float32: "F32",
    torch.bfloat16: "BF16",
    torch.int64: "I64",
}


@dataclass(frozen=True)
class TensorInfo:
    dtype: str  # safetensors dtype code: F32, BF16, I64
    shape: tuple[int, ...]


def sha256_hex(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def serialise(model: StackedDenoiser) -> tuple[bytes, WeightsDtype]:
    """The model's state dict as safetensors bytes, and the dtype of its network weights."""
    if len(model.layouts) != 1:
        raise PublishError(
            f"the store holds one skill model per version; this stack has {len(model.layouts)}: "
            "publish each model on its own"
        )
    # safetensors needs contiguous tensors that own their memory.
    state = {k: v.detach().to("cpu").contiguous().clone() for k, v in model.state_dict().items()}
    weights_dtype: WeightsDtype = "bfloat16" if model.precision == "bfloat16" else "float32"
    return safetensors.torch.save(state), weights_dtype


def implied_bytes_lower_bound(manifest: Manifest) -> int:
    """Bytes the transformer blocks alone take (attention, projections, MLP, modulation): a
    manifest implying more than the file holds describes another model, and is refused before
    anything is allocated for it."""
    config = manifest.architecture.dit
    h, mlp = config.hidden, int(config.hidden * config.mlp_ratio)
    per_block = 6 * h * h + 3 * h * h + h * h + 2 * h * mlp
    return config.depth * per_block * (2 if manifest.weights.dtype == "bfloat16" else 4)


def read_header(data: bytes, ref: str) -> dict[str, TensorInfo]:
    """Tensor names, dtypes and shapes from safetensors bytes, without loading any tensor."""
    if len(data) < 8:
        raise IntegrityError(f"weights of {ref} are {len(data)} bytes: too short to be safetensors")
    (header_size,) = struct.unpack("<Q", data[:8])
    if header_size > min(MAX_HEADER_BYTES, len(data) - 8):
        raise IntegrityError(f"weights of {ref} declare a {header_size}-byte header: not valid safetensors")
    try:
        header = json.loads(data[8 : 8 + header_size])
        return {
            name: TensorInfo(str(entry["dtype"]), tuple(int(n) for n in entry["shape"]))
            for name, entry in header.items()
            if name != "__metadata__"
        }
    except (ValueError, TypeError, KeyError, AttributeError) as error:
        raise IntegrityError(f"weights of {ref} have an unreadable safetensors header ({error})") from None


def build_skeleton(manifest: Manifest) -> StackedDenoiser:
    """The model the manifest describes, with fresh weights: the one model builder is the single
    source of truth for tensor names and shapes, and the checked weights load into this model."""
    layout = manifest.signature.layout
    mean = torch.tensor(manifest.normalisation.mean, dtype=torch.float32)
    std = torch.tensor(manifest.normalisation.std, dtype=torch.float32)
    model = single_model(layout, manifest.architecture.dit, mean, std)
    if manifest.weights.dtype != "float32":
        model = model.with_precision(manifest.weights.dtype)
    return model


def expected_tensors(skeleton: StackedDenoiser) -> dict[str, TensorInfo]:
    return {
        name: TensorInfo(_SAFETENSORS_DTYPES[tensor.dtype], tuple(tensor.shape))
        for name, tensor in skeleton.state_dict().items()
    }


def _compare_structure(
    manifest: Manifest, expected: dict[str, TensorInfo], found: dict[str, TensorInfo]
) -> None:
    problems = [f"missing tensor {n}" for n in sorted(expected.keys() - found.keys())]
    problems += [f"unexpected tensor {n}" for n in sorted(found.keys() - expected.keys())]
    for name in sorted(expected.keys() & found.keys()):
        want, got = expected[name], found[name]
        if want != got:
            problems.append(
                f"{name} is {got.dtype}{list(got.shape)}, the manifest implies {want.dtype}{list(want.shape)}"
            )
    if problems:
        shown = "; ".join(problems[:8]) + (f"; and {len(problems) - 8} more" if len(problems) > 8 else "")
        raise IntegrityError(
            f"manifest of {manifest.ref} does not match its weights: {shown}. The manifest describes "
            "another model; re-publish the weights with the manifest written from them"
        )


def _compare_statistics(manifest: Manifest, state: dict[str, torch.Tensor]) -> None:
    layout = manifest.signature.layout
    width = manifest.architecture.dit.max_token_dim
    mask = layout.dim_mask(width)
    for field in ("mean", "std"):
        stored = layout.unpad(state[field][0])
        recorded = torch.tensor(getattr(manifest.normalisation, field), dtype=torch.float32)
        if not torch.equal(stored, recorded) or (
            field == "std" and not bool((state[field][0][~mask] == 1).all())
        ):
            raise IntegrityError(
                f"normalisation.{field} in the manifest of {manifest.ref} differs from the {field} "
                "stored with its weights; re-publish the model rather than editing its manifest"
            )
    types = torch.tensor([[TOKEN_TYPES.index(t) for t in layout.types]])
    if not torch.equal(state["token_types"], types):
        raise IntegrityError(
            f"token types in the manifest of {manifest.ref} differ from those stored with its weights; "
            "re-publish the model rather than editing its manifest"
        )


def load_checked(manifest: Manifest, data: bytes) -> StackedDenoiser:
    """Run every check on ``data`` against ``manifest``, then return the ready-to-call model
    (eval mode); IntegrityError names the first check that fails."""
    if len(data) != manifest.weights.size_bytes:
        raise IntegrityError(
            f"weights of {manifest.ref} are {len(data)} bytes, the manifest says "
            f"{manifest.weights.size_bytes}: the file is truncated or was replaced; "
            "pull or publish it again"
        )
    digest = sha256_hex(data)
    if digest != manifest.weights.sha256:
        raise IntegrityError(
            f"weights of {manifest.ref} hash to sha256 {digest[:16]}..., the manifest says "
            f"{manifest.weights.sha256[:16]}...: the file is corrupt or was changed after "
            "publishing; pull or publish it again"
        )
    if implied_bytes_lower_bound(manifest) > len(data):
        raise IntegrityError(
            f"manifest of {manifest.ref} describes a network of at least "
            f"{implied_bytes_lower_bound(manifest)} bytes, but its weights are {len(data)} bytes: "
            "the manifest describes another model; re-publish the model"
        )
    model = build_skeleton(manifest)
    _compare_structure(manifest, expected_tensors(model), read_header(data, manifest.ref))
    try:
        state = safetensors.torch.load(data)
    except Exception as error:  # safetensors raises its own error types for malformed buffers
        raise IntegrityError(
            f"weights of {manifest.ref} cannot be decoded as safetensors ({error})"
        ) from None
    _compare_statistics(manifest, state)
    model.load_state_dict(state, strict=True)
    return model.eval()
