"""EDM preconditioning, schedules, samplers and the stacked DiT: analytic and structural checks."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from gfc.diffusion.denoiser import StackedDenoiser, TokenLayout, denoise_flat, single_model
from gfc.diffusion.edm import denoising_loss, edm_scalings, karras_sigmas
from gfc.diffusion.gaussian import GaussianFactor
from gfc.diffusion.network import DiTConfig
from gfc.diffusion.samplers import sample_euler, sample_heun

LAYOUT = TokenLayout((10, 9, 4, 10, 9), ("robot", "object", "action", "robot", "object"))
SMALL = DiTConfig(hidden=32, depth=1, heads=2)


def randomised(model: StackedDenoiser, seed: int) -> StackedDenoiser:
    """Fill every weight (DiT zero-initialises some) so outputs depend on every input."""
    g = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for p in model.network.parameters():
            p.copy_(torch.randn(p.shape, generator=g) * 0.2)
    return model.eval()


def test_karras_schedule_endpoints_and_order() -> None:
    s = karras_sigmas(50, 0.002, 80.0)
    assert s.shape == (51,)
    assert s[0] == pytest.approx(80.0) and s[-2] == pytest.approx(0.002, rel=1e-5) and s[-1] == 0
    assert bool((s[:-1] > s[1:]).all())


@given(st.floats(1e-3, 50.0), st.floats(1e-3, 5.0))
def test_edm_scalings_reproduce_data_at_every_level(sigma: float, sd: float) -> None:
    """For N(0, sd^2) data the ideal network output is 0 exactly when D = c_skip x is optimal,
    and c_skip^2 sd^2 + ... : check EDM's identities c_in^2 (sigma^2 + sd^2) = 1 and
    c_skip + c_out^2 / sd^2 = 1 (unit-variance training target)."""
    s = edm_scalings(torch.tensor(sigma, dtype=torch.float64), torch.tensor(sd, dtype=torch.float64))
    assert float(s.c_in**2 * (sigma**2 + sd**2)) == pytest.approx(1.0)
    assert float(s.c_skip + s.c_out**2 / sd**2) == pytest.approx(1.0)


def test_loss_of_the_exact_gaussian_denoiser_is_its_analytic_value() -> None:
    """For 1-D N(0, s^2) data the optimal denoiser has MSE s^2 sigma^2 / (s^2 + sigma^2); with the
    EDM weight 1/c_out^2 the expected loss is exactly 1."""
    g = torch.Generator().manual_seed(0)
    sd, sigma = 0.7, 0.4
    x0 = torch.randn(200_000, 1, generator=g, dtype=torch.float64) * sd
    x = x0 + sigma * torch.randn(x0.shape, generator=g, dtype=torch.float64)
    optimal = x * sd**2 / (sd**2 + sigma**2)
    loss = denoising_loss(
        optimal, x0, torch.full((x0.shape[0], 1), sigma, dtype=torch.float64), torch.tensor([sd])
    )
    assert float(loss) == pytest.approx(1.0, rel=0.02)


@pytest.mark.parametrize(("sampler", "steps"), [(sample_euler, 200), (sample_heun, 40)])
def test_samplers_reproduce_a_gaussian(sampler: object, steps: int) -> None:
    """The probability-flow ODE maps N(0, sigma_max^2) onto the data distribution; Euler, being
    first order, needs more steps than Heun for the same accuracy."""
    layout = TokenLayout((2,), ("object",))
    cov = torch.tensor([[1.0, 0.6], [0.6, 0.5]], dtype=torch.float64)
    factor = GaussianFactor(layout, torch.tensor([0.3, -0.2], dtype=torch.float64), cov)
    present = torch.ones(1, dtype=torch.bool)

    def denoiser(x: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
        return factor.denoise_flat(x, sigma.expand(x.shape[0]), present)

    g = torch.Generator().manual_seed(0)
    sigmas = karras_sigmas(steps, 0.002, 40.0, dtype=torch.float64)
    x = sampler(denoiser, torch.randn(20_000, 2, generator=g, dtype=torch.float64) * sigmas[0], sigmas)  # type: ignore[operator]
    assert torch.allclose(x.mean(0), factor.mean, atol=0.05)
    assert torch.allclose(torch.cov(x.T), cov, atol=0.05)


def test_network_output_shapes_and_zero_init() -> None:
    model = single_model(LAYOUT, SMALL)
    x = torch.randn(5, LAYOUT.total_dim)
    out = denoise_flat(model, x, torch.full((5,), 0.3))
    assert out.shape == (5, LAYOUT.total_dim)
    # adaLN-Zero: an untrained model is the pure skip connection around the data mean (0).
    s = edm_scalings(torch.tensor(0.3), torch.tensor(0.5))
    assert torch.allclose(out, s.c_skip * x, atol=1e-6)


def test_stacked_models_equal_individual_models() -> None:
    a = randomised(single_model(LAYOUT, SMALL), 1)
    b_layout = TokenLayout((10, 9, 9), ("robot", "object", "action"))
    b = randomised(single_model(b_layout, SMALL), 2)
    stack = StackedDenoiser.concatenate([a, b])
    g = torch.Generator().manual_seed(3)
    xa, xb = (
        torch.randn(4, LAYOUT.total_dim, generator=g),
        torch.randn(4, b_layout.total_dim, generator=g),
    )
    sigma = torch.full((4,), 0.7)
    x = torch.zeros(2, 4, 5, SMALL.max_token_dim)
    x[0] = LAYOUT.pad(xa, SMALL.max_token_dim)
    x[1, :, :3] = b_layout.pad(xb, SMALL.max_token_dim)
    present = torch.ones(2, 4, 5, dtype=torch.bool)
    present[1, :, 3:] = False
    out = stack.denoise(x, sigma.expand(2, 4), present)
    assert torch.allclose(LAYOUT.unpad(out[0]), denoise_flat(a, xa, sigma), atol=1e-5)
    assert torch.allclose(b_layout.unpad(out[1, :, :3]), denoise_flat(b, xb, sigma), atol=1e-5)


def test_models_trained_with_other_dropout_stack_and_other_architectures_do_not() -> None:
    """Dropout is a training setting: a bank may mix rates (ADR 0004), and then runs without."""
    a = randomised(single_model(LAYOUT, SMALL), 1)
    b = randomised(single_model(LAYOUT, replace(SMALL, dropout=0.0)), 2)
    stack = StackedDenoiser.concatenate([a, b])
    assert stack.network.config.dropout == 0.0
    x, sigma = torch.randn(3, LAYOUT.total_dim), torch.full((3,), 0.4)
    padded = LAYOUT.pad(x, SMALL.max_token_dim).expand(2, 3, 5, SMALL.max_token_dim)
    both = stack.denoise(padded, sigma.expand(2, 3), torch.ones(2, 3, 5, dtype=torch.bool))
    assert torch.allclose(LAYOUT.unpad(both[1]), denoise_flat(b, x, sigma), atol=1e-5)
    wider = single_model(LAYOUT, replace(SMALL, hidden=64))
    with pytest.raises(ValueError, match="hidden: 64 vs 32"):
        StackedDenoiser.concatenate([a, wider])


def test_rows_at_different_noise_levels_each_get_their_own_modulation() -> None:
    """Training batches mix noise levels: each row's output must equal that row denoised alone."""
    model = randomised(single_model(LAYOUT, SMALL), 7)
    g = torch.Generator().manual_seed(8)
    x = torch.randn(4, LAYOUT.total_dim, generator=g)
    sigma = torch.tensor([0.01, 0.2, 1.5, 6.0])
    together = denoise_flat(model, x, sigma)
    for i in range(4):
        alone = denoise_flat(model, x[i : i + 1], sigma[i : i + 1])
        assert torch.allclose(together[i : i + 1], alone, atol=1e-5), f"row {i}"


def test_absent_tokens_do_not_influence_present_ones() -> None:
    model = randomised(single_model(LAYOUT, SMALL), 4)
    x = torch.randn(3, LAYOUT.total_dim)
    present = torch.tensor([[True, True, False, False, True]]).expand(3, -1)
    out = denoise_flat(model, x, torch.full((3,), 0.5), present)
    changed = x.clone()
    changed[:, 19:33] += 5.0  # the action and the robot effect token (absent)
    out2 = denoise_flat(model, changed, torch.full((3,), 0.5), present)
    kept = torch.cat([torch.arange(0, 19), torch.arange(33, 42)])
    assert torch.allclose(out[:, kept], out2[:, kept], atol=1e-5)
    full = denoise_flat(model, changed, torch.full((3,), 0.5))
    assert not torch.allclose(full[:, kept], out[:, kept], atol=1e-3)  # and they would if present


def test_single_token_query_equals_masked_full_row() -> None:
    """A marginal query (one position carrying role r) is the full row with only token r present."""
    model = randomised(single_model(LAYOUT, SMALL), 5)
    g = torch.Generator().manual_seed(6)
    x = torch.randn(1, 3, LAYOUT.n_tokens, SMALL.max_token_dim, generator=g)
    x = x * LAYOUT.dim_mask(SMALL.max_token_dim)
    sigma = torch.full((1, 3), 0.2)
    for role in range(LAYOUT.n_tokens):
        present = torch.zeros(1, 3, LAYOUT.n_tokens, dtype=torch.bool)
        present[..., role] = True
        full = model.denoise(x, sigma, present)[:, :, role]
        query = model.denoise(
            x[:, :, role : role + 1],
            sigma,
            torch.ones(1, 3, 1, dtype=torch.bool),
            torch.full((1, 3, 1), role),
        )
        assert torch.allclose(full, query[:, :, 0], atol=1e-5), role


def test_bfloat16_bank_stays_close_to_float32() -> None:
    model = randomised(single_model(LAYOUT, SMALL), 7)
    x = torch.randn(8, LAYOUT.total_dim)
    sigma = torch.full((8,), 0.5)
    with torch.no_grad():
        ref = denoise_flat(model, x, sigma)
        low = denoise_flat(model.with_precision("bfloat16"), x, sigma)
    assert low.dtype == torch.float32
    assert float((ref - low).abs().max()) < 0.05 * float(ref.abs().max()) + 1e-3
    assert math.isfinite(float(low.sum()))
