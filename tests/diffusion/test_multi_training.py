"""Stacked training: M models trained as one stack learn exactly what each learns alone.

The equivalence test is exact up to float rounding because each model draws its batches from
its own generator in ``train_denoiser``'s order, gradients are clipped per model, and AdamW and
the EMA are element-wise; dropout is off (its masks are drawn for the whole stack).
"""

from __future__ import annotations

import copy

import pytest
import torch

from gfc.diffusion.denoiser import StackedDenoiser, TokenLayout, single_model
from gfc.diffusion.multi_training import (
    build_stack,
    clip_grad_norm_per_model,
    evaluate_stacked_loss,
    split_stack,
    train_stacked,
)
from gfc.diffusion.network import DiTConfig
from gfc.diffusion.training import (
    MIN_STD,
    TrainConfig,
    data_statistics,
    evaluate_loss,
    sample_model,
    train_denoiser,
)

# Two layouts with different token counts and dims: a 2-D object with a 1-D action, and a robot,
# an object and an action.
SHORT = TokenLayout((2, 1), ("object", "action"))
LONG = TokenLayout((3, 2, 1), ("robot", "object", "action"))
CONFIG = DiTConfig(hidden=32, depth=2, heads=2, dropout=0.0, max_token_dim=3, conditioning=True)


def gaussian(n: int, dim: int, mean: float, std: float, seed: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return torch.randn(n, dim, generator=g) * std + mean


def test_a_stack_trains_each_model_exactly_as_alone() -> None:
    data = [gaussian(300, SHORT.total_dim, 1.0, 0.3, 0), gaussian(200, LONG.total_dim, -1.0, 0.5, 1)]
    val = [gaussian(40, SHORT.total_dim, 1.0, 0.3, 2), gaussian(30, LONG.total_dim, -1.0, 0.5, 3)]
    config = TrainConfig(steps=40, batch_size=32, lr=1e-3, grad_clip=0.5)
    singles = []
    for seed, (layout, rows) in enumerate(zip((SHORT, LONG), data, strict=True)):
        torch.manual_seed(seed)
        singles.append(single_model(layout, CONFIG, *data_statistics(rows)))
    stack = StackedDenoiser.concatenate([copy.deepcopy(s) for s in singles])
    alone = [
        train_denoiser(model, rows, config, val_data=v, val_every=10)
        for model, rows, v in zip(singles, data, val, strict=True)
    ]
    joint = train_stacked(stack, data, config, val_data=val, val_every=10)

    for single, split in zip(alone, joint.results(), strict=True):
        assert split.losses == pytest.approx(single.losses, rel=1e-4, abs=1e-5)
        assert [s for s, _ in split.val_losses] == [10, 20, 30, 40]
        assert [v for _, v in split.val_losses] == pytest.approx([v for _, v in single.val_losses], rel=1e-4)
        want, got = single.model.state_dict(), split.model.state_dict()
        assert want.keys() == got.keys()
        for name, tensor in want.items():
            assert got[name].shape == tensor.shape, name
            torch.testing.assert_close(got[name], tensor, rtol=1e-4, atol=1e-5, msg=name)
    # The held-out evaluation of the stack is each model's evaluate_loss.
    stacked_val = evaluate_stacked_loss(joint.model, val, seed=3)
    alone_val = [evaluate_loss(r.model, v, seed=3) for r, v in zip(alone, val, strict=True)]
    assert stacked_val == pytest.approx(alone_val, rel=1e-5)


def test_gradients_are_clipped_per_model_as_clip_grad_norm_clips_one() -> None:
    layouts = [SHORT, LONG, SHORT]
    stack = build_stack(
        layouts, [gaussian(10, layout.total_dim, 0, 1, i) for i, layout in enumerate(layouts)], CONFIG
    )
    g = torch.Generator().manual_seed(0)
    scales = torch.tensor([0.001, 1.0, 30.0])  # (M,): under, near and over the threshold
    for p in stack.parameters():
        p.grad = torch.randn(p.shape, generator=g) * scales.view(-1, *([1] * (p.dim() - 1)))
    expected = []
    for m in range(len(layouts)):  # model m alone: its slices as the parameters of one model
        alone = []
        for p in stack.parameters():
            assert p.grad is not None
            alone.append(torch.nn.Parameter(p.detach()[m].clone()))
            alone[-1].grad = p.grad[m].clone()
        expected.append((torch.nn.utils.clip_grad_norm_(alone, 1.0), alone))
    norms = clip_grad_norm_per_model(stack.parameters(), 1.0)
    for m, (norm, alone) in enumerate(expected):
        torch.testing.assert_close(norms[m], norm)
        for p, q in zip(stack.parameters(), alone, strict=True):
            assert p.grad is not None and q.grad is not None
            torch.testing.assert_close(p.grad[m], q.grad)
    assert float(norms[0]) < 1.0 < float(norms[2])  # one model left alone, one clipped


def test_split_models_have_the_single_model_shape() -> None:
    stack = build_stack([SHORT, LONG], [gaussian(10, 3, 0, 1, 0), gaussian(10, 6, 0, 1, 1)], CONFIG)
    for split, layout in zip(split_stack(stack), (SHORT, LONG), strict=True):
        fresh = single_model(layout, CONFIG)
        assert {k: v.shape for k, v in split.state_dict().items()} == {
            k: v.shape for k, v in fresh.state_dict().items()
        }
        assert split.layouts == [layout]


def test_a_one_row_dataset_has_finite_statistics() -> None:
    """A model whose training split is one row (a tiny build) still gets publishable statistics."""
    mean, std = data_statistics(torch.tensor([[1.0, 2.0, 3.0]]))
    assert mean.tolist() == [1.0, 2.0, 3.0] and std.tolist() == pytest.approx([MIN_STD] * 3)


def first_dim_share_positive(samples: torch.Tensor) -> float:
    return float((samples[:, 0] > 0).float().mean())


@pytest.mark.slow
def test_jointly_trained_models_each_learn_their_own_distribution() -> None:
    """A bimodal 2-token model and a 3-token Gaussian model with a coupled action, trained in one
    stack: each model's samples match its own data, an untrained model's do not."""
    g = torch.Generator().manual_seed(0)
    n = 3000
    side = torch.randint(0, 2, (n,), generator=g).float() * 2 - 1
    obj = torch.stack([0.4 * side, torch.full((n,), 0.1)], dim=1) + 0.03 * torch.randn(n, 2, generator=g)
    bimodal = torch.cat([obj, -obj[:, :1] + 0.02 * torch.randn(n, 1, generator=g)], dim=1)  # action = -x
    robot = torch.tensor([0.5, -0.2, 0.3]) + 0.2 * torch.randn(n, 3, generator=g)
    target = torch.tensor([-0.3, 0.6]) + 0.2 * torch.randn(n, 2, generator=g)
    coupled = torch.cat(
        [robot, target, (target[:, :1] - robot[:, :1]) + 0.02 * torch.randn(n, 1, generator=g)], 1
    )
    data = [bimodal, coupled]
    config = TrainConfig(steps=700, batch_size=128, lr=1e-3, ema_decay=0.995)
    stack = build_stack([SHORT, LONG], data, CONFIG, seed=0)
    untrained = split_stack(stack)
    result = train_stacked(stack, data, config, val_data=[d[:200] for d in data], val_every=100)
    first, second = (r.model for r in result.results())
    for losses in result.val_losses:
        assert losses[-1][1] < losses[0][1]

    samples = sample_model(first, 600, generator=torch.Generator().manual_seed(1))
    assert 0.35 < first_dim_share_positive(samples) < 0.65  # both modes
    assert float((samples[:, 0].abs() - 0.4).abs().median()) < 0.08  # at the modes, not between
    assert float((samples[:, 2] + samples[:, 0]).abs().median()) < 0.08  # the action follows x
    raw = sample_model(untrained[0], 600, generator=torch.Generator().manual_seed(1))
    assert float((raw[:, 2] + raw[:, 0]).abs().median()) > 0.15

    samples = sample_model(second, 600, generator=torch.Generator().manual_seed(2))
    assert (samples.mean(0) - coupled.mean(0)).abs().max() < 0.06
    action_error = samples[:, 5] - (samples[:, 3] - samples[:, 0])
    assert float(action_error.abs().median()) < 0.06
    raw = sample_model(untrained[1], 600, generator=torch.Generator().manual_seed(2))
    assert float((raw[:, 5] - (raw[:, 3] - raw[:, 0])).abs().median()) > 0.15  # independent dims
