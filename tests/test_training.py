"""Training a DiT skill model on synthetic data: it learns a bimodal joint and its marginals."""

from __future__ import annotations

import pytest
import torch

from gfc.diffusion.denoiser import TokenLayout, single_model
from gfc.diffusion.network import DiTConfig
from gfc.diffusion.training import (
    TrainConfig,
    data_statistics,
    random_token_mask,
    sample_model,
    train_denoiser,
)

LAYOUT = TokenLayout((2, 1), ("object", "action"))
CONFIG = DiTConfig(hidden=64, depth=2, heads=2, dropout=0.0, conditioning=True)


def bimodal(n: int, seed: int) -> torch.Tensor:
    """Object at (+-0.3, 0.1) (two modes), action = 2 * object x + small noise: (n, 3)."""
    g = torch.Generator().manual_seed(seed)
    side = torch.randint(0, 2, (n,), generator=g).float() * 2 - 1
    obj = torch.stack([0.3 * side, torch.full((n,), 0.1)], dim=1) + 0.03 * torch.randn(n, 2, generator=g)
    action = 2 * obj[:, :1] + 0.02 * torch.randn(n, 1, generator=g)
    return torch.cat([obj, action], dim=1)


def check_samples(samples: torch.Tensor) -> tuple[float, float, float]:
    """(share of the + mode, worst |action - 2 x|, mean object y)."""
    plus = float((samples[:, 0] > 0).float().mean())
    coupling = float((samples[:, 2] - 2 * samples[:, 0]).abs().median())
    return plus, coupling, float(samples[:, 1].mean())


def test_token_mask_keeps_at_least_one_token() -> None:
    mask = random_token_mask(1000, 5, 0.5, torch.Generator().manual_seed(0))
    assert bool(mask.any(dim=1).all())
    dropped = ~mask.all(dim=1)
    assert 0.35 < float(dropped.float().mean()) < 0.55


@pytest.mark.slow
def test_trained_model_learns_the_joint_and_the_marginal() -> None:
    data = bimodal(4000, 0)
    mean, std = data_statistics(data)
    model = single_model(LAYOUT, CONFIG, mean, std)
    untrained = single_model(LAYOUT, CONFIG, mean, std).eval()
    result = train_denoiser(
        model,
        data,
        TrainConfig(steps=1500, batch_size=256, lr=1e-3, ema_decay=0.995),
        val_data=bimodal(500, 1),
    )
    assert result.val_losses[-1][1] < result.val_losses[0][1]

    g = torch.Generator().manual_seed(2)
    joint = sample_model(result.model, 1000, generator=g)
    plus, coupling, y = check_samples(joint)
    assert 0.35 < plus < 0.65  # both modes
    assert coupling < 0.08  # the action follows the object
    assert abs(y - 0.1) < 0.03

    # The marginal of the object token alone (what the planner's compensation queries).
    marginal = sample_model(result.model, 1000, present=torch.tensor([True, False]), generator=g)
    plus_m, _, y_m = check_samples(marginal)
    assert 0.35 < plus_m < 0.65
    assert abs(y_m - 0.1) < 0.03
    assert float(marginal[:, 0].abs().mean()) == pytest.approx(0.3, abs=0.05)

    # Conditioned on a clean object token in the + mode, the action follows it (2 x = 0.6).
    given_obj = torch.tensor([0.3, 0.1, 0.0])
    conditional = sample_model(result.model, 500, given=(torch.tensor([True, False]), given_obj), generator=g)
    assert torch.allclose(conditional[:, :2], given_obj[:2].expand(500, 2))  # the given token stays put
    assert float(conditional[:, 2].median()) == pytest.approx(0.6, abs=0.08)

    # The same checks fail for an untrained model (it only knows the data's mean and spread).
    _, coupling_u, _ = check_samples(sample_model(untrained, 1000, generator=g))
    assert coupling_u > 0.15
