"""Dataset format (atomic shards, hashes, resume) and ``gfc train`` publishing to the store."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from gfc.data.dataset import DatasetError, DatasetWriter, load_dataset, read_index
from gfc.diffusion.denoiser import TokenLayout
from skill_store import SkillStore

LAYOUT = TokenLayout((10, 9, 9, 10, 9), ("robot", "object", "action", "robot", "object"))


def synthetic_rows(n: int, seed: int) -> torch.Tensor:
    """A pick-like rule: the effect equals the pre state moved by the action's position."""
    g = torch.Generator().manual_seed(seed)
    pre = torch.randn(n, 19, generator=g) * 0.1
    action = torch.randn(n, 9, generator=g) * 0.05
    effect = pre.clone()
    effect[:, :3] += action[:, :3]
    effect[:, 10:13] += action[:, :3]
    return torch.cat([pre, action, effect], dim=1)


def test_shards_round_trip_and_resume(tmp_path: Path) -> None:
    writer = DatasetWriter(tmp_path, "pick.cube", LAYOUT, {"command": "test"})
    writer.add_shard(synthetic_rows(30, 0), attempts=40, failures={"1": 6, "3": 4})
    resumed = DatasetWriter(tmp_path, "pick.cube", LAYOUT)  # an interrupted collection picks up here
    assert resumed.next_shard == 1
    resumed.add_shard(synthetic_rows(20, 1), attempts=25, failures={"2": 5})
    data, index = load_dataset(tmp_path)
    assert data.shape == (50, LAYOUT.total_dim)
    assert [s.rows for s in index.shards] == [30, 20]
    assert index.shards[0].success_rate == pytest.approx(0.75)
    assert json.loads((tmp_path / "dataset.json").read_text())["content_hash"] == index.content_hash
    with pytest.raises(DatasetError, match=r"holds pick\.cube"):
        DatasetWriter(tmp_path, "pick.hammer", LAYOUT)


def test_a_flipped_byte_in_a_shard_is_refused(tmp_path: Path) -> None:
    DatasetWriter(tmp_path, "pick.cube", LAYOUT).add_shard(synthetic_rows(10, 0), 10, {})
    shard = tmp_path / read_index(tmp_path).shards[0].file
    raw = bytearray(shard.read_bytes())
    raw[-3] ^= 0x55
    shard.write_bytes(bytes(raw))
    with pytest.raises(DatasetError, match="sha256"):
        load_dataset(tmp_path)


def test_missing_dataset_says_how_to_make_one(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="gfc collect"):
        read_index(tmp_path)


@pytest.mark.slow
def test_gfc_train_publishes_a_checked_version_with_its_record(tmp_path: Path) -> None:
    data_dir = tmp_path / "pick.cube"
    DatasetWriter(data_dir, "pick.cube", LAYOUT).add_shard(synthetic_rows(400, 0), 500, {"1": 100})
    store = tmp_path / "skills"
    out = subprocess.run(
        [sys.executable, "-m", "gfc.cli", "train", "pick.cube", "--data", str(data_dir), "--steps", "60",
         "--batch-size", "64", "--hidden", "32", "--depth", "1", "--store", str(store), "--alias", "latest"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert out.returncode == 0, out.stdout + out.stderr
    assert "published pick.cube@1" in out.stdout
    assert (data_dir / "loss.png").read_bytes()[:4] == b"\x89PNG"
    skills = SkillStore(store)
    manifest = skills.manifest("pick.cube@latest")
    assert manifest.training.data_hash == read_index(data_dir).content_hash
    assert "held_out_loss" in manifest.training.metrics
    assert "gfc train pick.cube" in (manifest.training.command or "")
    model = skills.load("pick.cube@1")  # integrity-checked load
    assert model.layouts[0].dims == LAYOUT.dims
    wrong = subprocess.run(
        [sys.executable, "-m", "gfc.cli", "train", "pick.hammer", "--data", str(data_dir), "--steps", "1",
         "--store", str(store)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert wrong.returncode == 2 and "holds data for 'pick.cube'" in wrong.stdout
