"""Publishing, resolving, loading and integrity checks, on a local folder and on memory://."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import torch

import skill_store
from gfc.diffusion.denoiser import StackedDenoiser, TokenLayout, denoise_flat
from gfc.diffusion.network import DiTConfig
from gfc.planner.library import stack_models
from skill_store import (
    IntegrityError,
    InvalidNameError,
    ManifestError,
    PublishError,
    SkillNotFoundError,
    SkillStore,
)
from skill_store.manifest import MANIFEST_FILE, WEIGHTS_FILE
from tests.skill_store.conftest import random_model

MOVE_LAYOUT = TokenLayout((10, 9, 10, 9), ("robot", "action", "robot", "object"))


def outputs(model: StackedDenoiser) -> torch.Tensor:
    generator = torch.Generator().manual_seed(1)
    x = torch.randn(5, model.layouts[0].total_dim, generator=generator)
    return denoise_flat(model, x, torch.linspace(0.05, 2.0, 5))


def rewrite(store: SkillStore, name: str, version: int, file: str, data: bytes) -> None:
    """Change a published file behind the store's back (corruption, tampering)."""
    folder = store.backend.path(name, str(version))
    store.backend.fs.makedirs(folder, exist_ok=True)
    store.backend.fs.pipe_file(f"{folder}/{file}", data)


def read(store: SkillStore, name: str, version: int, file: str) -> bytes:
    return bytes(store.backend.fs.cat_file(store.backend.path(name, str(version), file)))


def test_a_published_model_loads_back_identical(store: SkillStore, model: StackedDenoiser) -> None:
    version = store.publish("pick.hammer", model, {"seed": 7, "metrics": {"loss": 0.25}})
    loaded = store.load(f"pick.hammer@{version}")
    assert version == 1
    assert not loaded.training
    assert torch.equal(outputs(loaded), outputs(model))
    for key, tensor in model.state_dict().items():
        assert torch.equal(loaded.state_dict()[key], tensor), key


def test_the_manifest_records_signature_statistics_and_provenance(
    store: SkillStore, model: StackedDenoiser
) -> None:
    metadata = {
        "data_hash": "sha256:abc",
        "metrics": {"success": 0.9},
        "seed": 3,
        "command": "gfc train pick",
    }
    store.publish("pick.hammer", model, metadata)
    manifest = store.manifest("pick.hammer")
    assert manifest.signature.skill == "pick"
    assert [t.role for t in manifest.signature.tokens] == ["robot", "object", "action", "robot", "object"]
    assert [t.phase for t in manifest.signature.tokens] == ["pre", "pre", "action", "effect", "effect"]
    assert manifest.signature.action_frame == "grasp (end-effector) pose in the object frame"
    assert manifest.architecture.dit == DiTConfig(hidden=32, depth=1, heads=2)
    assert manifest.training.model_dump(exclude_none=True) == {**metadata}
    assert manifest.normalisation.mean == pytest.approx(model.layouts[0].unpad(model.mean[0]).tolist())
    assert manifest.created_at.utcoffset() is not None
    assert manifest.weights.size_bytes == len(read(store, "pick.hammer", 1, WEIGHTS_FILE))


def test_versions_count_up_and_resolve(store: SkillStore) -> None:
    for seed in range(3):
        store.publish("pick.hammer", random_model(seed))
    assert store.versions("pick.hammer") == (1, 2, 3)
    assert str(store.resolve("pick.hammer")) == "pick.hammer@3"  # no 'latest' alias: highest
    assert str(store.resolve("pick.hammer@2")) == "pick.hammer@2"
    store.set_alias("pick.hammer@1", "latest")
    assert str(store.resolve("pick.hammer")) == "pick.hammer@1"  # an explicit 'latest' pins
    store.set_alias("pick.hammer@2", "production")
    assert torch.equal(outputs(store.load("pick.hammer@production")), outputs(random_model(1)))


def test_unknown_skills_versions_and_aliases_say_what_exists(
    store: SkillStore, model: StackedDenoiser
) -> None:
    store.publish("pick.hammer", model)
    with pytest.raises(SkillNotFoundError, match=r"no published version of place\.hammer"):
        store.resolve("place.hammer.box")
    with pytest.raises(SkillNotFoundError, match=r"no version 9 .*published: 1"):
        store.resolve("pick.hammer@9")
    with pytest.raises(SkillNotFoundError, match=r"no alias 'production'.*gfc skills alias"):
        store.resolve("pick.hammer@production")


def test_an_empty_or_missing_store_lists_nothing(store: SkillStore) -> None:
    assert store.skills() == []
    assert store.verify() == []


def test_a_flipped_byte_in_the_weights_is_refused(store: SkillStore, model: StackedDenoiser) -> None:
    store.publish("pick.hammer", model)
    data = bytearray(read(store, "pick.hammer", 1, WEIGHTS_FILE))
    data[len(data) // 2] ^= 0x01
    rewrite(store, "pick.hammer", 1, WEIGHTS_FILE, bytes(data))
    with pytest.raises(IntegrityError, match=r"sha256.*corrupt or was changed"):
        store.load("pick.hammer@1")
    [result] = store.verify()
    assert not result.ok and "sha256" in (result.problem or "")


def test_truncated_weights_are_refused(store: SkillStore, model: StackedDenoiser) -> None:
    store.publish("pick.hammer", model)
    rewrite(store, "pick.hammer", 1, WEIGHTS_FILE, read(store, "pick.hammer", 1, WEIGHTS_FILE)[:-4])
    with pytest.raises(IntegrityError, match="bytes, the manifest says"):
        store.load("pick.hammer")


def edit_manifest(store: SkillStore, edit: Callable[[dict[str, Any]], None]) -> None:
    manifest = json.loads(read(store, "pick.hammer", 1, MANIFEST_FILE))
    edit(manifest)
    rewrite(store, "pick.hammer", 1, MANIFEST_FILE, json.dumps(manifest).encode())


def test_a_manifest_that_describes_other_shapes_is_refused(store: SkillStore, model: StackedDenoiser) -> None:
    store.publish("pick.hammer", model)
    # The sha256 still matches: only the shapes can tell.
    edit_manifest(store, lambda m: m["architecture"]["config"].update(max_token_dim=12))
    with pytest.raises(
        IntegrityError,
        match=r"does not match its weights: .*enc_w is F32\[1, 3, 10, 32\], the manifest implies F32\[1, 3, 12, 32\]",
    ):
        store.load("pick.hammer")
    assert not store.verify()[0].ok


@pytest.mark.parametrize("size", [{"hidden": 64}, {"hidden": 4096, "depth": 64, "mlp_ratio": 16}])
def test_a_manifest_that_describes_a_bigger_network_is_refused_before_building_it(
    store: SkillStore, model: StackedDenoiser, size: dict[str, int]
) -> None:
    store.publish("pick.hammer", model)
    edit_manifest(store, lambda m: m["architecture"]["config"].update(size))
    with pytest.raises(
        IntegrityError, match=r"describes a network of at least \d+ bytes, but its weights are"
    ):
        store.load("pick.hammer")


@pytest.mark.parametrize(
    ("config", "problem"),
    [
        ({"hidden": 32.5}, "must be an integer"),
        ({"depth": 10_000}, "outside"),
        ({"exec": 1}, "unknown DiTConfig"),
    ],
)
def test_a_manifest_with_an_impossible_config_is_refused(
    store: SkillStore, model: StackedDenoiser, config: dict[str, float], problem: str
) -> None:
    store.publish("pick.hammer", model)
    edit_manifest(store, lambda m: m["architecture"]["config"].update(config))
    with pytest.raises(ManifestError, match=problem):
        store.load("pick.hammer")


def test_a_manifest_with_another_layout_is_refused(store: SkillStore, model: StackedDenoiser) -> None:
    store.publish("pick.hammer", model)
    manifest = json.loads(read(store, "pick.hammer", 1, MANIFEST_FILE))
    manifest["signature"]["tokens"] = [
        {"dim": d, "type": t} for d, t in zip(MOVE_LAYOUT.dims, MOVE_LAYOUT.types, strict=True)
    ]
    manifest["normalisation"] = {"mean": [0.0] * 38, "std": [1.0] * 38}
    rewrite(store, "pick.hammer", 1, MANIFEST_FILE, json.dumps(manifest).encode())
    with pytest.raises(IntegrityError, match="does not match its weights"):
        store.load("pick.hammer")


def test_edited_statistics_are_refused(store: SkillStore, model: StackedDenoiser) -> None:
    store.publish("pick.hammer", model)
    manifest = json.loads(read(store, "pick.hammer", 1, MANIFEST_FILE))
    manifest["normalisation"]["std"][0] *= 2
    rewrite(store, "pick.hammer", 1, MANIFEST_FILE, json.dumps(manifest).encode())
    with pytest.raises(IntegrityError, match=r"normalisation.std .* differs"):
        store.load("pick.hammer")


def test_a_manifest_with_unknown_fields_is_refused(store: SkillStore, model: StackedDenoiser) -> None:
    store.publish("pick.hammer", model)
    manifest = json.loads(read(store, "pick.hammer", 1, MANIFEST_FILE))
    manifest["loader"] = "os.system"
    rewrite(store, "pick.hammer", 1, MANIFEST_FILE, json.dumps(manifest).encode())
    with pytest.raises(ManifestError, match="loader"):
        store.load("pick.hammer")


def test_a_version_folder_copied_under_another_number_is_refused(
    store: SkillStore, model: StackedDenoiser
) -> None:
    store.publish("pick.hammer", model)
    for file in (WEIGHTS_FILE, MANIFEST_FILE):
        rewrite(store, "pick.hammer", 2, file, read(store, "pick.hammer", 1, file))
    with pytest.raises(IntegrityError, match=r"describes pick\.hammer@1, not pick\.hammer@2"):
        store.load("pick.hammer@2")


@pytest.mark.parametrize("name", ["../pick.hammer", "pick/../../x", "/abs", "..", "pick.hammer/1"])
def test_path_traversal_names_are_refused_everywhere(
    store: SkillStore, model: StackedDenoiser, name: str
) -> None:
    with pytest.raises(InvalidNameError):
        store.publish(name, model)
    with pytest.raises(InvalidNameError):
        store.load(name)
    with pytest.raises(InvalidNameError):
        store.versions(name)
    store.publish("pick.hammer", model)
    with pytest.raises(InvalidNameError):
        store.set_alias("pick.hammer@1", name)


def test_alias_moves_are_logged_with_their_previous_target(store: SkillStore) -> None:
    for seed in range(2):
        store.publish("pick.hammer", random_model(seed))
    store.set_alias("pick.hammer@1", "production", reason="first rollout")
    store.set_alias("pick.hammer@2", "production")
    store.remove_alias("pick.hammer", "production")
    log = [(e.event, e.alias, e.previous, e.version) for e in store.audit_log("pick.hammer")]
    assert log == [
        ("published", None, None, 1),
        ("published", None, None, 2),
        ("alias_moved", "production", None, 1),
        ("alias_moved", "production", 1, 2),
        ("alias_removed", "production", 2, None),
    ]
    assert store.audit_log("pick.hammer")[2].reason == "first rollout"
    assert store.aliases("pick.hammer") == {}


def test_publish_can_move_aliases(store: SkillStore, model: StackedDenoiser) -> None:
    version = store.publish("pick.hammer", model, aliases=["latest", "canary"])
    assert store.aliases("pick.hammer") == {"latest": version, "canary": version}
    with pytest.raises(InvalidNameError):
        store.publish("pick.hammer", model, aliases=["../production"])
    assert store.versions("pick.hammer") == (version,)


def test_an_alias_cannot_point_at_a_missing_version(store: SkillStore, model: StackedDenoiser) -> None:
    store.publish("pick.hammer", model)
    with pytest.raises(SkillNotFoundError):
        store.set_alias("pick.hammer@5", "production")
    assert store.audit_log("pick.hammer")[-1].event == "published"


def test_a_half_written_version_is_invisible(store: SkillStore, model: StackedDenoiser) -> None:
    store.publish("pick.hammer", model)
    # A publisher that died after the weights, before the manifest (object stores), or a
    # folder being copied in by hand.
    rewrite(store, "pick.hammer", 2, WEIGHTS_FILE, read(store, "pick.hammer", 1, WEIGHTS_FILE))
    assert store.versions("pick.hammer") == (1,)
    assert str(store.resolve("pick.hammer")) == "pick.hammer@1"
    assert store.publish("pick.hammer", random_model(1)) == 3  # the number is never reused


def test_the_manifest_is_written_last(store: SkillStore, model: StackedDenoiser) -> None:
    written: list[str] = []
    pipe_file = store.backend.fs.pipe_file

    def recording(path: str, data: bytes, **kwargs: object) -> None:
        written.append(path.rsplit("/", 1)[-1])
        pipe_file(path, data, **kwargs)

    store.backend.fs.pipe_file = recording
    try:
        store.backend.publish_folder({WEIGHTS_FILE: b"w", MANIFEST_FILE: b"m"}, MANIFEST_FILE, "x.y", "1")
    finally:
        del store.backend.fs.pipe_file
    if written:  # object stores write file by file; the local backend renames a whole folder
        assert written[-1] == MANIFEST_FILE
    assert store.backend.exists("x.y", "1", WEIGHTS_FILE)


def test_publish_refuses_stacks_and_unknown_metadata(store: SkillStore, model: StackedDenoiser) -> None:
    with pytest.raises(PublishError, match="publish each model on its own"):
        store.publish("pick.hammer", stack_models([model, model]))
    with pytest.raises(PublishError, match="unknown metadata keys"):
        store.publish("pick.hammer", model, {"sede": 1})
    assert store.skills() == []


def test_bfloat16_models_round_trip(store: SkillStore, model: StackedDenoiser) -> None:
    half = model.with_precision("bfloat16")
    store.publish("pick.hammer", half)
    loaded = store.load("pick.hammer", precision="stored")
    assert loaded.precision == "bfloat16"
    assert torch.equal(outputs(loaded), outputs(half))
    # By default the network computes in float32 with the very same (bfloat16-exact) weights.
    upcast = store.load("pick.hammer")
    assert upcast.precision == "float32"
    for key, tensor in upcast.state_dict().items():
        assert torch.equal(tensor, half.state_dict()[key].float()), key


def test_skills_without_a_catalogue_entry_get_a_plain_signature(store: SkillStore) -> None:
    store.publish("custom.thing", random_model(0, MOVE_LAYOUT))
    signature = store.manifest("custom.thing").signature
    assert signature.skill is None and [t.dim for t in signature.tokens] == [10, 9, 10, 9]
    assert store.skills() == ["custom.thing"]


def test_exclusive_creation_lets_exactly_one_writer_win(store: SkillStore) -> None:
    assert store.backend.create_exclusive(b"first", "pick.hammer", ".claims", "1")
    assert not store.backend.create_exclusive(b"second", "pick.hammer", ".claims", "1")
    assert store.backend.read_bytes("pick.hammer", ".claims", "1", max_bytes=64) == b"first"


def test_a_claimed_number_is_never_published_twice(store: SkillStore, model: StackedDenoiser) -> None:
    store.backend.create_exclusive(b"{}", "pick.hammer", ".claims", "1")  # a publisher mid-way or dead
    assert store.publish("pick.hammer", model) == 2
    assert store.versions("pick.hammer") == (2,)


def test_no_module_of_the_store_can_unpickle() -> None:
    # Loading must never run code: no pickle, no torch.load, no eval of manifest strings.
    sources = Path(skill_store.__file__).parent.rglob("*.py")
    forbidden = re.compile(
        r"^\s*(import|from)\s+(pickle|dill|cloudpickle|joblib|marshal)\b"
        r"|(?<!safetensors\.)torch\.load\(|(?<![.\w])(eval|exec)\(",
        re.MULTILINE,
    )
    offenders = [str(p) for p in sources if forbidden.search(p.read_text())]
    assert offenders == []


def test_verify_of_an_unknown_skill_is_an_error_not_an_empty_success(store: SkillStore) -> None:
    with pytest.raises(SkillNotFoundError, match=r"no published version of pick\.hammer"):
        store.verify(["pick.hammer"])


def test_metrics_that_json_cannot_hold_are_refused_at_publish(
    store: SkillStore, model: StackedDenoiser
) -> None:
    with pytest.raises(PublishError, match="not finite"):
        store.publish("pick.hammer", model, {"metrics": {"loss": float("nan")}})
    assert store.skills() == []


def test_a_manifest_that_would_not_read_back_is_refused_before_a_number_is_spent(
    store: SkillStore, model: StackedDenoiser
) -> None:
    store.publish("pick.hammer", model)
    manifest, data = store.weights_bytes("pick.hammer@1")
    # model_copy skips validation, as a hand-built manifest might.
    broken = manifest.model_copy(
        update={"name": "pick.wrench", "created_at": manifest.created_at.replace(tzinfo=None)}
    )
    with pytest.raises(PublishError, match="created_at"):
        store.publish_checkpoint(broken, data)
    assert store.publish_checkpoint(manifest.model_copy(update={"name": "pick.wrench"}), data) == 1


def test_stray_files_do_not_disturb_listings(store: SkillStore, model: StackedDenoiser) -> None:
    store.publish("pick.hammer", model, aliases=["production"])
    for stray in (
        "README.md",
        ".DS_Store",
        "Bad Name/1/manifest.json",
        "pick.hammer/notes.txt",
        "pick.hammer/aliases/Bad.json",
    ):
        store.backend.replace_file(b"junk", *stray.split("/"))
    assert store.skills() == ["pick.hammer"]
    assert store.versions("pick.hammer") == (1,)
    assert store.aliases("pick.hammer") == {"production": 1}
