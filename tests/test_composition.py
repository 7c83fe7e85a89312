"""The composed sampler against closed-form Gaussian products (the paper's Eq. 5).

Every factor is an analytic Gaussian with its exact denoiser, so the distribution the planner
should sample is known exactly: the product of the factors, divided by the square root of the
two factors' marginals on every node shared by two temporal factors, times any spatial
(linear-Gaussian) factor. With Langevin correction the sampler matches it.

Tolerance: every sampled mean and covariance entry lies within Z_TOL Monte-Carlo standard
errors of the closed form (standard error of a mean: sqrt(C_ii / N); of a covariance entry:
sqrt((C_ii C_jj + C_ij^2) / N)), taking the worst entry.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from gfc.diffusion.gaussian import GaussianBank, GaussianFactor
from gfc.plan.graph import CompiledPlan, SpatialFactor
from gfc.planner.composed import Compensation, ComposedScore
from gfc.planner.layout import VariableLayout
from gfc.planner.sampling import SamplingSettings, sample_graph
from tests.graphs import InformationForm, factor, layout_of, plan_of, random_gaussian, vector_node

N_SAMPLES = 3000
# Annealed Langevin: 100 levels, 5 corrector steps each with step size 0.5 sigma^2.
SETTINGS = SamplingSettings(steps=100, sampler="euler", sigma_max=10.0, corrector_steps=5, corrector_snr=0.5)
Z_TOL = 5.0  # worst entry, in Monte-Carlo standard errors


def z_index(plan: CompiledPlan, layout: VariableLayout, tokens_of: int) -> list[int]:
    """z indices of a factor's flat token dimensions, in token order."""
    out: list[int] = []
    for t in plan.temporal[tokens_of].tokens:
        start = layout.node_offset[t.node] if t.node is not None else layout.action_offset[t.action]  # type: ignore[index]
        out += list(range(start, start + t.dim))
    return out


def token_dims(gf: GaussianFactor, token: int) -> list[int]:
    o, d = gf.layout.offsets[token], gf.layout.dims[token]
    return list(range(o, o + d))


def closed_form(
    plan: CompiledPlan,
    factors: list[GaussianFactor],
    compensation: Compensation,
    extra: InformationForm | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    layout = VariableLayout.of(plan)
    form = extra or InformationForm(layout.free_dim)
    degree = plan.temporal_degree()
    for f_idx, (tf, gf) in enumerate(zip(plan.temporal, factors, strict=True)):
        idx = z_index(plan, layout, f_idx)
        form.add_factor(gf, idx)
        if compensation == "none":
            continue
        for t, token in enumerate(tf.tokens):
            if token.node is not None and degree[token.node] >= 2:
                d = degree[token.node]
                node_idx = list(
                    range(layout.node_offset[token.node], layout.node_offset[token.node] + token.dim)
                )
                form.add_marginal(gf, token_dims(gf, t), node_idx, -(d - 1) / d)
    return form.moments()


def sample(
    plan: CompiledPlan, factors: list[GaussianFactor], compensation: Compensation, seed: int = 0
) -> np.ndarray:
    composed = ComposedScore(plan, GaussianBank(factors), compensation=compensation)
    with torch.no_grad():
        z = sample_graph(composed, N_SAMPLES, SETTINGS, torch.Generator().manual_seed(seed))
    return z.double().numpy()


def moment_errors(z: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> tuple[float, float]:
    """Worst mean and covariance deviations, in Monte-Carlo standard errors."""
    n = z.shape[0]
    var = np.diag(cov)
    mean_z = np.abs(z.mean(0) - mean) / np.sqrt(var / n)
    cov_se = np.sqrt((np.outer(var, var) + cov**2) / n)
    cov_z = np.abs(np.cov(z.T) - cov) / cov_se
    return float(mean_z.max()), float(cov_z.max())


def chain() -> tuple[CompiledPlan, list[GaussianFactor]]:
    """s0 -a0-> s1 -a1-> s2: s1 is shared by two temporal factors."""
    dims = {0: 2, 1: 2, 2: 2}
    nodes = [vector_node(i, "s", i, 2) for i in range(3)]
    f1 = factor(0, "f1", [0], 0, [1], dims)
    f2 = factor(1, "f2", [1], 1, [2], dims)
    plan = plan_of(nodes, 2, [f1, f2])
    return plan, [random_gaussian(layout_of(f1), 1), random_gaussian(layout_of(f2), 2)]


def pot() -> tuple[CompiledPlan, list[GaussianFactor]]:
    """Two arms act on one pot at once: P0 and P1 are each shared by both temporal factors."""
    dims = {0: 1, 1: 1, 2: 2, 3: 1, 4: 1, 5: 2}  # L0 R0 P0 L1 R1 P1
    names = ["L", "R", "P", "L", "R", "P"]
    nodes = [vector_node(i, names[i], i // 3, dims[i]) for i in range(6)]
    f1 = factor(0, "left", [0, 2], 0, [3, 5], dims)
    f2 = factor(1, "right", [1, 2], 1, [4, 5], dims)
    plan = plan_of(nodes, 2, [f1, f2])
    # Tight marginals on the pot make double counting visible.
    return plan, [
        random_gaussian(layout_of(f1), 3, floor=0.2),
        random_gaussian(layout_of(f2), 4, floor=0.2),
    ]


@pytest.mark.slow
def test_chain_matches_closed_form() -> None:
    plan, factors = chain()
    mean, cov = closed_form(plan, factors, "marginal")
    mean_err, cov_err = moment_errors(sample(plan, factors, "marginal"), mean, cov)
    assert mean_err < Z_TOL, mean_err
    assert cov_err < Z_TOL, cov_err


@pytest.mark.slow
def test_parallel_pair_joined_by_spatial_factor() -> None:
    """Two independent arms (L, C) and (R, M) coupled only by a spatial factor C1 - M1 = d."""
    dims = {0: 1, 1: 2, 2: 1, 3: 2, 4: 1, 5: 2, 6: 1, 7: 2}  # L0 C0 R0 M0 L1 C1 R1 M1
    nodes = [vector_node(i, "LCRM"[i % 4], i // 4, dims[i]) for i in range(8)]
    f1 = factor(0, "left", [0, 1], 0, [4, 5], dims)
    f2 = factor(1, "right", [2, 3], 1, [6, 7], dims)
    offset = [0.5, -0.25]
    tolerance = 0.5  # energy precision 1 / 0.5^2 = 4 per dimension
    spatial = SpatialFactor(
        "offset",
        "constraint",
        0,
        (5, 7),
        {"offset": offset, "tolerance": tolerance, "weight": 1.0, "gain": 2.0},
    )
    plan = plan_of(nodes, 2, [f1, f2], (spatial,))
    factors = [random_gaussian(layout_of(f1), 5), random_gaussian(layout_of(f2), 6)]

    layout = VariableLayout.of(plan)
    extra = InformationForm(layout.free_dim)
    c1 = list(range(layout.node_offset[5], layout.node_offset[5] + 2))
    m1 = list(range(layout.node_offset[7], layout.node_offset[7] + 2))
    w = 1.0 / tolerance**2
    # exp(-w/2 |C1 - M1 - d|^2) in information form
    for i in range(2):
        extra.precision[c1[i], c1[i]] += w
        extra.precision[m1[i], m1[i]] += w
        extra.precision[c1[i], m1[i]] -= w
        extra.precision[m1[i], c1[i]] -= w
        extra.shift[c1[i]] += w * offset[i]
        extra.shift[m1[i]] -= w * offset[i]
    mean, cov = closed_form(plan, factors, "marginal", extra)
    z = sample(plan, factors, "marginal")
    mean_err, cov_err = moment_errors(z, mean, cov)
    assert mean_err < Z_TOL, mean_err
    assert cov_err < Z_TOL, cov_err
    # The coupling is real: C1 and M1 are correlated only through the spatial factor.
    assert abs(np.corrcoef(z[:, c1[0]], z[:, m1[0]])[0, 1]) > 0.3


@pytest.mark.slow
def test_shared_pot_node_matches_closed_form_with_compensation() -> None:
    plan, factors = pot()
    mean, cov = closed_form(plan, factors, "marginal")
    mean_err, cov_err = moment_errors(sample(plan, factors, "marginal"), mean, cov)
    assert mean_err < Z_TOL, mean_err
    assert cov_err < Z_TOL, cov_err


@pytest.mark.slow
def test_removing_compensation_breaks_the_shared_node_case() -> None:
    """Without the -1/2 marginal terms the sampler double counts the pot's marginals: its samples
    no longer match the paper's distribution, by far more than the tolerance above."""
    plan, factors = pot()
    mean, cov = closed_form(plan, factors, "marginal")
    mean_err, cov_err = moment_errors(sample(plan, factors, "none"), mean, cov)
    assert max(mean_err, cov_err) > 3 * Z_TOL, (mean_err, cov_err)
    # ... while it does sample its own (uncompensated) product correctly.
    mean_none, cov_none = closed_form(plan, factors, "none")
    mean_err, cov_err = moment_errors(sample(plan, factors, "none"), mean_none, cov_none)
    assert mean_err < Z_TOL and cov_err < Z_TOL, (mean_err, cov_err)


def conditioned_on_first(
    factors: list[GaussianFactor], plan: CompiledPlan, observed: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """Closed form of the (compensated) chain s0 -> s1 [-> s2] given s0 = observed."""
    layout = VariableLayout.of(plan)
    form = InformationForm(2 + layout.free_dim)
    a0 = 2 + layout.action_offset[0]
    s1 = [2 + layout.node_offset[1], 3 + layout.node_offset[1]]
    form.add_factor(factors[0], [0, 1, a0, *s1])  # token order: s0, a0, s1
    if len(factors) == 2:
        a1 = 2 + layout.action_offset[1]
        s2 = [2 + layout.node_offset[2], 3 + layout.node_offset[2]]
        form.add_factor(factors[1], [*s1, a1, *s2])
        form.add_marginal(factors[0], token_dims(factors[0], 2), s1, -0.5)
        form.add_marginal(factors[1], token_dims(factors[1], 0), s1, -0.5)
    p, h = form.precision, form.shift
    cov = np.linalg.inv(p[2:, 2:])
    return cov @ (h[2:] - p[2:, :2] @ np.array(observed)), cov


def observed_chain(length: int) -> tuple[CompiledPlan, list[GaussianFactor], tuple[float, float]]:
    dims = {0: 2, 1: 2, 2: 2}
    observed = (0.8, -0.6)
    nodes = [vector_node(0, "s", 0, 2, observed), *[vector_node(i, "s", i, 2) for i in range(1, length + 1)]]
    fs = [factor(i, f"f{i}", [i], i, [i + 1], dims) for i in range(length)]
    return (
        plan_of(nodes, length, fs),
        [random_gaussian(layout_of(f), 7 + i) for i, f in enumerate(fs)],
        observed,
    )


def sample_known(
    plan: CompiledPlan, factors: list[GaussianFactor], known: str, settings: SamplingSettings
) -> np.ndarray:
    composed = ComposedScore(plan, GaussianBank(factors), known=known)  # type: ignore[arg-type]
    with torch.no_grad():
        return sample_graph(composed, N_SAMPLES, settings, torch.Generator().manual_seed(0)).double().numpy()


@pytest.mark.slow
def test_observed_node_conditions_exactly_when_given_clean() -> None:
    """One factor with an observed pre node, plain ODE sampling (the planner's default): clean
    conditioning tokens give the exact conditional; the replacement method (observed +
    sigma * eps) is visibly off."""
    plan, factors, observed = observed_chain(1)
    mean, cov = conditioned_on_first(factors, plan, observed)
    ode = SamplingSettings(steps=60, sampler="heun", sigma_max=40.0)
    mean_err, cov_err = moment_errors(sample_known(plan, factors, "clean", ode), mean, cov)
    assert mean_err < Z_TOL and cov_err < Z_TOL, (mean_err, cov_err)
    mean_err, cov_err = moment_errors(sample_known(plan, factors, "noised", ode), mean, cov)
    assert max(mean_err, cov_err) > 2 * Z_TOL, (mean_err, cov_err)


@pytest.mark.slow
def test_observed_chain_with_shared_node_matches_the_conditional() -> None:
    plan, factors, observed = observed_chain(2)
    mean, cov = conditioned_on_first(factors, plan, observed)
    mean_err, cov_err = moment_errors(sample_known(plan, factors, "clean", SETTINGS), mean, cov)
    assert mean_err < Z_TOL and cov_err < Z_TOL, (mean_err, cov_err)
