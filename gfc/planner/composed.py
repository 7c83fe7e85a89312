"""The composed score of a compiled factor graph (the paper's Algorithm 1, batched).

Variables
    ``z`` (B, N): every free node version (world frame) and every action, for B candidates.
    Known nodes (the observed scene) are not variables: at noise level ``sigma`` they enter the
    models as ``observed + sigma * eps`` with one fixed ``eps`` per candidate, so model inputs
    look like training inputs along a consistent forward trajectory.

Score of the joint distribution (paper Eq. 5 / Algorithm 1)
    sum over temporal factors of the skill model's score (mapped from the acting robot's frame to
    the world frame), minus the compensation for nodes shared by temporal factors, plus the
    guidance of spatial factors (``gfc.constraints``, noised to the current level).

Compensation
    The paper divides by ``sqrt(p_1(v) p_2(v))`` for a node ``v`` shared by two temporal factors,
    i.e. subtracts half of each factor's *marginal* score of ``v``. We get the marginal by
    evaluating the skill model with only ``v``'s token present (models are trained with random
    token dropping). For a node in ``d`` temporal factors (a pot lifted by two arms and then
    moved by both: d = 4) the Bethe generalisation subtracts ``(d-1)/d`` of each marginal score;
    for d = 2 that is the paper's 1/2. See docs/adr/0001-composition.md.

Batching
    All factor instances (and marginal queries) of one skill model are rows of one batch, and all
    skill models of the plan are stacked along a model dimension, so one sampling step is *one*
    network call. ``per_factor=True`` evaluates the same math with one call per factor (the
    benchmark's baseline).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import torch

from gfc.diffusion.denoiser import StackedDenoiserProtocol
from gfc.geometry import POSE9_DIM, pose9_frame_map
from gfc.plan.graph import CompiledPlan
from gfc.planner.layout import VariableLayout, known_values_of
from gfc.planner.spatial import SpatialTerms

KnownNodes = Literal["auto", "clean", "noised"]
"""How observed nodes enter the skill models: "clean" (as observed, flagged, for models trained
with clean conditioning tokens: exact conditionals), "noised" (observed + sigma * eps, the
replacement method: approximate), "auto" (clean when every model accepts it)."""

Compensation = Literal["marginal", "mean", "none"]
"""How nodes shared by several temporal factors are counted once: "marginal" subtracts
(d-1)/d of each factor's marginal score (exact, one extra single-token row per factor and shared
node); "mean" averages the factors' joint-score components instead (DESIGN.md's reading of the
paper: no extra rows, but not the gradient of a density); "none" is the ablation."""


def _token_frame(dim: int, world_from_model: np.ndarray, is_pose: bool) -> tuple[np.ndarray, np.ndarray]:
    """Affine map world -> model frame for one token: (dim, dim) orthogonal matrix and offset."""
    a, b = np.eye(dim), np.zeros(dim)
    if is_pose:
        a9, b9 = pose9_frame_map(world_from_model)
        a[:9, :9], b[:9] = a9, b9
    return a, b


class ComposedScore:
    """Index tensors for one plan and its model stack; evaluates the joint score.

    The stack has one entry per temporal factor (F entries; a model used twice appears twice),
    so every entry sees exactly B rows (one per candidate) and no padding across models. Each
    factor's marginal queries for shared nodes form a second batch of single-token rows:
    (F, Q*B, 1, D). Shapes: F factors, B candidates, T tokens, Q queries per factor, D dims.
    """

    def __init__(
        self,
        plan: CompiledPlan,
        bank: StackedDenoiserProtocol,
        known_values: torch.Tensor | None = None,
        compensation: Compensation = "marginal",
        known: KnownNodes = "auto",
    ) -> None:
        if len(bank.layouts) != len(plan.temporal):
            raise ValueError(
                f"the model stack has {len(bank.layouts)} entries for {len(plan.temporal)} factors"
            )
        self.plan = plan
        self.bank = bank
        self.layout = VariableLayout.of(plan)
        n_factors, d_max = len(plan.temporal), bank.max_dim
        n_tokens = max(len(f.tokens) for f in plan.temporal)
        degree = plan.temporal_degree()
        self.n_factors, self.n_tokens, self.d_max = n_factors, n_tokens, d_max

        full_dim = self.layout.free_dim + self.layout.known_dim
        self.dummy = full_dim  # index of an extra zero column for padding
        src = np.full((n_factors, n_tokens, d_max), self.dummy, dtype=np.int64)
        weight = np.zeros((n_factors, n_tokens, d_max), dtype=np.float32)
        frame_a = np.tile(np.eye(d_max, dtype=np.float32), (n_factors, n_tokens, 1, 1))
        frame_b = np.zeros((n_factors, n_tokens, d_max), dtype=np.float32)
        present = np.zeros((n_factors, n_tokens), dtype=bool)
        known_token = np.zeros((n_factors, n_tokens), dtype=bool)
        queries: list[list[tuple[int, float]]] = [[] for _ in range(n_factors)]

        for f, factor in enumerate(plan.temporal):
            want = tuple(t.dim for t in factor.tokens)
            if bank.layouts[f].dims != want:
                raise ValueError(
                    f"step {factor.step}: model {factor.model!r} has token dims "
                    f"{bank.layouts[f].dims}, the plan needs {want}"
                )
            world_from_model = np.asarray(factor.world_from_model)
            for t, token in enumerate(factor.tokens):
                if token.node is not None:
                    node = plan.nodes[token.node]
                    if node.known:
                        start = self.layout.free_dim + self.layout.known_offset[node.id]
                    else:
                        start = self.layout.node_offset[node.id]
                    is_pose = node.dim >= POSE9_DIM  # robot and object states start with a pose9
                    free = not node.known
                    known_token[f, t] = node.known
                    d = degree[node.id]
                    shared = free and d >= 2
                    if shared and compensation == "marginal":
                        queries[f].append((t, -(d - 1) / d))
                    share = 1.0 / d if shared and compensation == "mean" else 1.0
                else:
                    assert token.action is not None
                    start = self.layout.action_offset[token.action]
                    is_pose, free, share = False, True, 1.0
                src[f, t, : token.dim] = np.arange(start, start + token.dim)
                a, b = _token_frame(token.dim, world_from_model, is_pose)
                frame_a[f, t, : token.dim, : token.dim] = a
                frame_b[f, t, : token.dim] = b
                present[f, t] = True
                if free:  # known nodes are clamped: their scores go nowhere
                    weight[f, t, : token.dim] = share

        n_queries = max(1, max(len(q) for q in queries))
        query_token = np.zeros((n_factors, n_queries), dtype=np.int64)
        query_weight = np.zeros((n_factors, n_queries), dtype=np.float32)
        for f, qs in enumerate(queries):
            for q, (t, w) in enumerate(qs):
                query_token[f, q], query_weight[f, q] = t, w
        self.queries = queries
        self.has_queries = any(queries)

        dtype = torch.get_default_dtype()
        self.src = torch.from_numpy(src)  # (F, T, D) index into [z | known | 0]
        self.weight = torch.from_numpy(weight).to(dtype)  # (F, T, D)
        self.frame_a = torch.from_numpy(frame_a).to(dtype)  # (F, T, D, D) world -> model
        self.frame_b = torch.from_numpy(frame_b).to(dtype)  # (F, T, D)
        self.present = torch.from_numpy(present)  # (F, T)
        accepts_clean = bool(getattr(bank, "accepts_clean", False))
        if known == "clean" and not accepts_clean:
            raise ValueError(
                "these skill models were not trained with clean conditioning tokens; use known='noised'"
            )
        self.clean_known = known == "clean" or (known == "auto" and accepts_clean)
        self.known_token = torch.from_numpy(known_token)  # (F, T)
        self.query_token = torch.from_numpy(query_token)  # (F, Q)
        qt = self.query_token
        rows = torch.arange(n_factors).unsqueeze(1)
        self.query_src = self.src[rows, qt]  # (F, Q, D)
        self.query_frame_a = self.frame_a[rows, qt]  # (F, Q, D, D)
        self.query_weight = torch.from_numpy(query_weight).to(dtype)[..., None] * self.weight[rows, qt].ne(
            0
        )  # (F, Q, D)
        self.known_values = known_values if known_values is not None else known_values_of(plan, self.layout)
        self.spatial = SpatialTerms(plan, self.layout, self.known_values)

    # ------------------------------------------------------------------ model scores
    def gather(self, full: torch.Tensor) -> torch.Tensor:
        """[z | known] (B, N+K) -> model-frame factor inputs (F, B, T, D)."""
        padded = torch.cat([full, full.new_zeros(full.shape[0], 1)], dim=1)
        x = padded[:, self.src]  # (B, F, T, D)
        return torch.einsum("ftij,bftj->fbti", self.frame_a, x) + self.frame_b.unsqueeze(1)

    def query_inputs(self, x: torch.Tensor) -> torch.Tensor:
        """The single-token rows of the marginal queries. (F, B, T, D) -> (F, Q*B, 1, D)."""
        f, b, _, d = x.shape
        idx = self.query_token[:, :, None, None].expand(f, -1, b, d)  # (F, Q, B, D)
        xq = x.permute(0, 2, 1, 3).gather(1, idx)  # (F, Q, B, D)
        return xq.reshape(f, -1, 1, d)

    def scatter(self, score_full: torch.Tensor, score_query: torch.Tensor | None) -> torch.Tensor:
        """Scores in model frames -> the weighted world-frame score on z. (B, N)

        score_full: (F, B, T, D); score_query: (F, Q*B, 1, D) or None.
        """
        b = score_full.shape[1]
        # Scores transform with A^T when inputs transform with A (A orthogonal).
        s = torch.einsum("ftji,fbtj->bfti", self.frame_a, score_full) * self.weight
        out = score_full.new_zeros(b, self.dummy + 1)
        out.scatter_add_(1, self.src.reshape(1, -1).expand(b, -1), s.reshape(b, -1))
        if score_query is not None:
            f, _, _, d = score_query.shape
            sq = score_query.reshape(f, -1, b, d)  # (F, Q, B, D)
            sq = torch.einsum("fqji,fqbj->bfqi", self.query_frame_a, sq) * self.query_weight
            out.scatter_add_(1, self.query_src.reshape(1, -1).expand(b, -1), sq.reshape(b, -1))
        return out[:, : self.layout.free_dim]

    def evaluate(
        self, x: torch.Tensor, xq: torch.Tensor | None, sigma: torch.Tensor, per_factor: bool
    ) -> tuple[torch.Tensor, torch.Tensor | None]:
        """Denoise factor rows (F, B, T, D) and query rows (F, Q*B, 1, D)."""
        f, b, t, _ = x.shape
        present = self.present.unsqueeze(1).expand(f, b, t)
        clean = self.known_token.unsqueeze(1).expand(f, b, t) if self.clean_known else None
        q_roles = None
        if xq is not None:
            q_roles = self.query_token.unsqueeze(2).expand(-1, -1, b).reshape(f, -1, 1)
        if not per_factor:
            level = sigma.reshape(1, 1).expand(f, 1)  # one noise level for every row
            if xq is None:
                return self.bank.denoise(x, level, present, clean=clean), None
            assert q_roles is not None
            # One pass: the queries ride along as lone tokens of the same matmuls.
            out, out_lone = self.bank.denoise_with_lone(
                x, level, present, xq.squeeze(2), q_roles.squeeze(2), clean=clean
            )
            return out, out_lone.unsqueeze(2)
        singles = getattr(self.bank, "singles", None)
        if singles is None:
            raise ValueError("per-factor evaluation needs a stack with per-factor models ('singles')")
        out = x.clone()
        out_q = None if xq is None else xq.clone()
        for i in range(f):
            n_tok = len(self.plan.temporal[i].tokens)
            out[i : i + 1, :, :n_tok] = singles[i].denoise(
                x[i : i + 1, :, :n_tok],
                sigma.reshape(1, 1),
                present[i : i + 1, :, :n_tok],
                clean=None if clean is None else clean[i : i + 1, :, :n_tok],
            )
            n_q = len(self.queries[i])
            if xq is not None and out_q is not None and n_q:
                rows = slice(0, n_q * b)
                assert q_roles is not None
                out_q[i : i + 1, rows] = singles[i].denoise(
                    xq[i : i + 1, rows],
                    sigma.reshape(1, 1),
                    torch.ones(1, n_q * b, 1, dtype=torch.bool),
                    q_roles[i : i + 1, rows],
                )
        return out, out_q

    def model_score(
        self,
        z: torch.Tensor,
        sigma: torch.Tensor,
        known_noise: torch.Tensor,
        per_factor: bool = False,
    ) -> torch.Tensor:
        """Sum of temporal factor scores with compensation, on z. z: (B, N) -> (B, N)."""
        # Known nodes: exactly as observed for models trained with clean tokens (exact
        # conditioning); otherwise noised to the current level (the replacement method).
        known = (
            self.known_values.expand(z.shape[0], -1)
            if self.clean_known
            else self.known_values + sigma * known_noise
        )
        full = torch.cat([z, known], dim=1)
        x = self.gather(full)
        xq = self.query_inputs(x) if self.has_queries else None
        denoised, denoised_q = self.evaluate(x, xq, sigma, per_factor)
        score_q = None
        if xq is not None and denoised_q is not None:
            score_q = (denoised_q - xq) / sigma**2
        return self.scatter((denoised - x) / sigma**2, score_q)

    # ------------------------------------------------------------------ spatial factors
    def spatial_residuals(self, z: torch.Tensor) -> list[torch.Tensor]:
        return self.spatial.residuals(z)

    def spatial_cost(self, z: torch.Tensor) -> torch.Tensor:
        return self.spatial.cost(z)

    def guidance(self, z: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
        return self.spatial.guidance(z, sigma)

    # ------------------------------------------------------------------ the composed model
    def score(
        self,
        z: torch.Tensor,
        sigma: torch.Tensor,
        known_noise: torch.Tensor,
        per_factor: bool = False,
    ) -> torch.Tensor:
        return self.model_score(z, sigma, known_noise, per_factor) + self.guidance(z, sigma)
