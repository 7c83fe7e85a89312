"""Models split out of a trained stack publish to and load from the skill store unchanged, and
denoise exactly as their slice of the stack does."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from gfc.diffusion.denoiser import StackedDenoiser, TokenLayout
from gfc.diffusion.multi_training import build_stack, split_stack, train_stacked
from gfc.diffusion.network import DiTConfig
from gfc.diffusion.training import TrainConfig
from skill_store import SkillStore

PICK = TokenLayout((10, 9, 9, 10, 9), ("robot", "object", "action", "robot", "object"))
PLACE = TokenLayout((10, 9, 9, 9, 10, 9), ("robot", "object", "action", "object", "robot", "object"))
SMALL = DiTConfig(hidden=32, depth=1, heads=2, conditioning=True)


def trained_stack() -> StackedDenoiser:
    """A stack of a place model (6 tokens) and a pick model (5: padded), a few steps trained and
    then every weight randomised, so that a mix-up of models or tokens shows in the outputs."""
    g = torch.Generator().manual_seed(0)
    data = [torch.randn(50, PLACE.total_dim, generator=g), torch.randn(40, PICK.total_dim, generator=g) + 1]
    stack = build_stack([PLACE, PICK], data, SMALL, seed=0)
    train_stacked(stack, data, TrainConfig(steps=3, batch_size=8))
    with torch.no_grad():
        for p in stack.network.parameters():
            p.add_(torch.randn(p.shape, generator=g) * 0.1)
    return stack.eval()


def stack_outputs(stack: StackedDenoiser, x: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
    """x: (M, B, T, D) -> (M, B, T, D), each model's own tokens present, noisy and clean mixed."""
    m, b, t, _ = x.shape
    present = torch.zeros(m, b, t, dtype=torch.bool)
    for i, layout in enumerate(stack.layouts):
        present[i, :, : layout.n_tokens] = True
    clean = present & (torch.arange(t) == 1)  # the object given clean
    return stack.denoise(x, sigma, present, clean=clean)


@pytest.mark.parametrize("precision", ["float32", "bfloat16"])
def test_split_models_round_trip_through_the_store(tmp_path: Path, precision: str) -> None:
    stack = trained_stack()
    store = SkillStore(tmp_path / "store")
    g = torch.Generator().manual_seed(1)
    t, d = stack.network.n_tokens, stack.max_dim
    x = torch.randn(2, 16, t, d, generator=g)  # (M, B, T, D)
    sigma = torch.rand(2, 16, generator=g) * 2 + 0.01  # (M, B)
    want = stack_outputs(stack if precision == "float32" else stack.with_precision("bfloat16"), x, sigma)
    for m, (name, single) in enumerate(zip(("place.cube.box", "pick.cube"), split_stack(stack), strict=True)):
        single = single.with_precision(precision)  # type: ignore[arg-type]
        version = store.publish(name, single, {"seed": 0}, aliases=("latest",))
        loaded = store.load(f"{name}@{version}", precision="stored")
        assert loaded.layouts == single.layouts == [stack.layouts[m]]
        saved, read = single.state_dict(), loaded.state_dict()
        assert saved.keys() == read.keys()
        for key, tensor in saved.items():
            assert torch.equal(read[key], tensor), key
        n = stack.layouts[m].n_tokens
        got = stack_outputs(loaded, x[m : m + 1, :, :n], sigma[m : m + 1])
        dims = stack.layouts[m].dim_mask(d)  # (T_m, D): compare the real dimensions only
        torch.testing.assert_close(got[0][:, dims], want[m, :, :n][:, dims], rtol=1e-5, atol=1e-5)
