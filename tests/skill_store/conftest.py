"""Fixtures for the skill store: every store test runs on a local folder and on memory://."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from pathlib import Path

import fsspec
import pytest
import torch

from gfc.diffusion.denoiser import StackedDenoiser, TokenLayout, single_model
from gfc.diffusion.network import DiTConfig
from skill_store import SkillStore

# The pick layout: robot, object, grasp action, robot and object after.
PICK_LAYOUT = TokenLayout((10, 9, 9, 10, 9), ("robot", "object", "action", "robot", "object"))
SMALL = DiTConfig(hidden=32, depth=1, heads=2)


def random_model(seed: int = 0, layout: TokenLayout = PICK_LAYOUT) -> StackedDenoiser:
    """A small model whose every weight and statistic is random, so a mix-up shows in outputs."""
    generator = torch.Generator().manual_seed(seed)
    mean = torch.randn(layout.total_dim, generator=generator)
    std = torch.rand(layout.total_dim, generator=generator) + 0.5
    model = single_model(layout, SMALL, mean, std)
    with torch.no_grad():
        for param in model.parameters():
            param.copy_(torch.randn(param.shape, generator=generator) * 0.1)
    return model.eval()


@pytest.fixture(params=["local", "memory"])
def store_location(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    if request.param == "local":
        yield str(tmp_path / "store")
        return
    root = f"/skill-store-test-{uuid.uuid4().hex}"
    yield f"memory://{root}"
    memory = fsspec.filesystem("memory")
    if memory.exists(root):
        memory.rm(root, recursive=True)


@pytest.fixture
def store(store_location: str) -> SkillStore:
    return SkillStore(store_location)


@pytest.fixture
def model() -> StackedDenoiser:
    return random_model(0)
