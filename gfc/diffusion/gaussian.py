"""Analytic Gaussian "skill models" with exact denoisers, for testing the composition.

For data ``x0 ~ N(mu, Sigma)`` and ``x = x0 + sigma * eps`` the optimal denoiser is
``E[x0 | x] = mu + Sigma (Sigma + sigma^2 I)^-1 (x - mu)``, and for a subset S of tokens (the
marginal the planner asks for with ``present``) the same formula on the S block. A product of
such factors is Gaussian in closed form, so sampled moments can be checked against it.
"""

from __future__ import annotations

import torch

from gfc.diffusion.denoiser import TokenLayout


class GaussianFactor:
    """One factor: a Gaussian over the flat concatenation of its tokens."""

    def __init__(self, layout: TokenLayout, mean: torch.Tensor, cov: torch.Tensor) -> None:
        if mean.shape != (layout.total_dim,) or cov.shape != (layout.total_dim, layout.total_dim):
            raise ValueError(f"mean/cov shapes {tuple(mean.shape)}/{tuple(cov.shape)} do not fit {layout}")
        if not torch.allclose(cov, cov.T) or torch.linalg.eigvalsh(cov).min() <= 0:
            raise ValueError("covariance must be symmetric positive definite")
        self.layout, self.mean, self.cov = layout, mean.double(), cov.double()

    def dims_of(self, present: torch.Tensor) -> torch.Tensor:
        """Flat dimension indices of the present tokens. present: (T,) bool -> (K,) long."""
        idx = [
            torch.arange(o, o + d)
            for o, d, p in zip(self.layout.offsets, self.layout.dims, present.tolist(), strict=True)
            if p
        ]
        return torch.cat(idx)

    def denoise_flat(
        self, x: torch.Tensor, sigma: torch.Tensor, present: torch.Tensor, clean: torch.Tensor | None = None
    ) -> torch.Tensor:
        """x: (R, total_dim), sigma: (R,), present / clean: (T,) bool (one pattern for all rows).

        Clean tokens are observed exactly (noise variance 0): the result is the exact posterior
        mean of the present tokens given the noisy ones and the clean ones.
        """
        dims = self.dims_of(present)
        mu = self.mean[dims]
        cov = self.cov[dims][:, dims]
        noisy = torch.ones(len(dims), dtype=torch.float64)
        if clean is not None and bool(clean.any()):
            clean_dims = set(self.dims_of(clean & present).tolist())
            noisy = torch.tensor([0.0 if int(d) in clean_dims else 1.0 for d in dims], dtype=torch.float64)
        xs = x[:, dims].double() - mu  # (R, K)
        out = x.clone()
        if bool((sigma == sigma[0]).all()):  # one level for all rows: one K x K solve
            noise = torch.diag(noisy * float(sigma[0]) ** 2)
            gain = torch.linalg.solve(cov + noise, cov)  # (K, K)
            out[:, dims] = (mu + xs @ gain).to(x.dtype)
            return out
        noisy_cov = cov.unsqueeze(0) + torch.diag_embed(sigma.double().view(-1, 1) ** 2 * noisy)  # (R, K, K)
        sol = torch.linalg.solve(noisy_cov, xs.unsqueeze(-1)).squeeze(-1)  # (R, K)
        out[:, dims] = (mu + sol @ cov).to(x.dtype)  # cov symmetric: (cov @ sol^T)^T
        return out


class GaussianBank:
    """M Gaussian factors behind the planner's stacked interface (``StackedDenoiserProtocol``)."""

    def __init__(self, factors: list[GaussianFactor], max_dim: int | None = None) -> None:
        self.factors = factors
        self.layouts = [f.layout for f in factors]
        self.max_dim = max_dim or max(max(layout.dims) for layout in self.layouts)

    accepts_clean = True  # exact conditionals are available in closed form

    @property
    def singles(self) -> list[GaussianBank]:
        return [GaussianBank([f], self.max_dim) for f in self.factors]

    def denoise_with_lone(
        self,
        x: torch.Tensor,
        sigma: torch.Tensor,
        present: torch.Tensor,
        lone_x: torch.Tensor,
        lone_roles: torch.Tensor,
        clean: torch.Tensor | None = None,
    ) -> tuple[torch.Tensor, torch.Tensor]:
        m, r, _ = lone_x.shape
        ones = torch.ones(m, r, 1, dtype=torch.bool)
        lone = self.denoise(lone_x.unsqueeze(2), sigma, ones, lone_roles.unsqueeze(2))
        return self.denoise(x, sigma, present, clean=clean), lone.squeeze(2)

    def denoise(
        self,
        x: torch.Tensor,
        sigma: torch.Tensor,
        present: torch.Tensor,
        roles: torch.Tensor | None = None,
        clean: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """Same contract as ``StackedDenoiser.denoise``; positions are scattered to their roles."""
        m_count, b, t_in, d = x.shape
        sigma = sigma.expand(m_count, b)
        if roles is None:
            roles = torch.arange(t_in).expand(m_count, b, t_in)
        out = x.clone()
        for m, factor in enumerate(self.factors):
            t = factor.layout.n_tokens
            # Put every position into its role slot: (R, T_model, D), absent slots stay zero.
            slots = x.new_zeros(b, t, d)
            pres = torch.zeros(b, t, dtype=torch.bool)
            clean_slots = torch.zeros(b, t, dtype=torch.bool)
            rows = torch.arange(b).unsqueeze(1).expand(b, t_in)  # (R, T_in) row of each position
            keep = present[m]
            slots[rows[keep], roles[m][keep]] = x[m][keep]
            pres[rows[keep], roles[m][keep]] = True
            if clean is not None:
                clean_slots[rows[keep], roles[m][keep]] = clean[m][keep]
            flat = factor.layout.unpad(slots)  # (R, total)
            # Group rows by which tokens they carry (a bitmask per row: cheap to deduplicate).
            bits = torch.arange(t)
            codes = (pres.long() << bits).sum(dim=1) + (clean_slots.long() << (bits + t)).sum(dim=1)  # (R,)
            result = flat.clone()
            for code in torch.unique(codes).tolist():
                pattern = (code >> bits) & 1 == 1
                clean_pattern = (code >> (bits + t)) & 1 == 1
                if not pattern.any():
                    continue
                sel = codes == code
                result[sel] = factor.denoise_flat(flat[sel], sigma[m, sel], pattern, clean_pattern)
            denoised = factor.layout.pad(result, self.max_dim)  # (R, T_model, D)
            out[m][keep] = denoised[rows[keep], roles[m][keep]]
        return out
