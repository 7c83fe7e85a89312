"""DiT-style score network over node and action tokens, with a leading *model* dimension.

One token per node and one for the action (the paper's appendix: DiT with hidden 128, 2 blocks,
2 heads, MLP ratio 2). Tokens are encoded by a linear encoder shared per token *type* (robot,
object, action) plus a learned *role* embedding per position; adaLN-Zero blocks condition on the
noise level.

Every parameter carries a leading dimension M: the network is a *stack* of M independent models
of identical size. A single skill model is M = 1; the planner concatenates all skill models of a
plan along M and runs them in one batched forward pass per sampling step (``torch.bmm`` over
models), instead of one pass per model or per factor. Inputs are padded to (M, B, T, D_max).

Token presence: ``present`` (M, B, T) marks the tokens that take part. Absent tokens are
excluded from attention, so the model evaluates the *marginal* of the present tokens when it
was trained with random token dropping (``gfc.diffusion.denoiser``). GFC's compensation term
needs exactly that: the score of one node under one skill's marginal.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

TOKEN_TYPES = ("robot", "object", "action")


@dataclass(frozen=True)
class DiTConfig:
    hidden: int = 128  # token width
    depth: int = 2  # transformer blocks
    heads: int = 2  # attention heads
    mlp_ratio: float = 2.0  # MLP width / hidden
    dropout: float = 0.1  # in attention output and MLP (training only)
    max_token_dim: int = 10  # widest token (a robot node: pose 9 + gripper 1)
    freq_dim: int = 64  # sinusoidal noise-level embedding width
    conditioning: bool = False  # trained with clean (observed) tokens: the planner may pass them clean

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DiTConfig:
        return cls(**data)


def _param(*shape: int, std: float = 0.0) -> nn.Parameter:
    tensor = torch.zeros(*shape)
    if std > 0:
        nn.init.trunc_normal_(tensor, std=std)
    return nn.Parameter(tensor)


def _linear(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor) -> torch.Tensor:
    """Per-model linear layer. x: (M, N, in), weight: (M, in, out), bias: (M, out) -> (M, N, out)."""
    return torch.baddbmm(bias.unsqueeze(1), x, weight)


def _per_token(modulation: torch.Tensor, t: int) -> torch.Tensor:
    """(M, 1, K) stays (it broadcasts over tokens); (M, B, K), one per row, -> (M, B*T, K)."""
    return modulation if modulation.shape[1] == 1 else modulation.repeat_interleave(t, dim=1)


class DiTStack(nn.Module):
    """M DiT score networks of one size, evaluated together.

    forward(x, c_noise, roles, token_types, present):
        x:           (M, B, T, D_max) preconditioned inputs, zero in padded dimensions
        c_noise:     (M, B) noise conditioning
        roles:       (M, B, T) long, the model's token slot at each position
        token_types: (M, B, T) long, index into TOKEN_TYPES
        present:     (M, B, T) bool
        returns      (M, B, T, D_max)
    """

    freqs: torch.Tensor  # sinusoid frequencies (buffer)

    def __init__(self, config: DiTConfig, n_models: int, n_tokens: int) -> None:
        super().__init__()
        self.config = config
        m, h, d, t = n_models, config.hidden, config.max_token_dim, n_tokens
        mlp = int(h * config.mlp_ratio)
        n_types = len(TOKEN_TYPES)
        std = 0.02
        self.enc_w = _param(m, n_types, d, h, std=1 / math.sqrt(d))
        self.enc_b = _param(m, n_types, h)
        self.role_emb = _param(m, t, h, std=std)
        self.clean_emb = _param(m, h, std=std)  # marks a clean (conditioning) token
        self.t_w1 = _param(m, config.freq_dim, h, std=std)
        self.t_b1 = _param(m, h)
        self.t_w2 = _param(m, h, h, std=std)
        self.t_b2 = _param(m, h)
        self.blocks = nn.ModuleList(
            _Block(m, h, mlp, config.heads, config.dropout) for _ in range(config.depth)
        )
        self.final_mod_w = _param(m, h, 2 * h)  # adaLN-Zero: starts at zero
        self.final_mod_b = _param(m, 2 * h)
        self.dec_w = _param(m, n_types, h, d)  # zero: the network starts by predicting nothing
        self.dec_b = _param(m, n_types, d)
        freqs = torch.exp(-math.log(10_000.0) * torch.arange(config.freq_dim // 2) / (config.freq_dim // 2))
        self.register_buffer("freqs", freqs, persistent=False)

    @property
    def n_models(self) -> int:
        return int(self.enc_w.shape[0])

    @property
    def n_tokens(self) -> int:
        return int(self.role_emb.shape[1])

    def noise_embedding(self, c_noise: torch.Tensor) -> torch.Tensor:
        """(M, B) -> (M, B, H). c_noise = ln(sigma)/4 spans about [-1.6, 0.3]; scale it up."""
        # Computed in float32 even when the weights are bfloat16: the phases need the precision.
        args = (c_noise.float() * 250.0).unsqueeze(-1) * self.freqs.float()  # (M, B, F/2)
        emb = torch.cat([torch.cos(args), torch.sin(args)], dim=-1).to(self.t_w1.dtype)  # (M, B, F)
        hidden = F.silu(_linear(emb, self.t_w1, self.t_b1))
        return _linear(hidden, self.t_w2, self.t_b2)

    def forward(
        self,
        x: torch.Tensor,
        c_noise: torch.Tensor,
        roles: torch.Tensor,
        token_types: torch.Tensor,
        present: torch.Tensor,
        lone: tuple[torch.Tensor, torch.Tensor, torch.Tensor] | None = None,
        clean: torch.Tensor | None = None,
    ) -> torch.Tensor | tuple[torch.Tensor, torch.Tensor]:
        """Rows of tokens, plus optionally lone tokens, through M networks in one pass.

        x: (M, B, T, D) rows of tokens; c_noise: (M, B), or (M, 1) when every row shares one
        level (the adaLN modulation is then computed once per model, not once per row);
        roles, token_types: (M, B, T) long (the model's token slot at each position, and its
        type); present: (M, B, T) bool (absent tokens are masked out of attention).

        lone: (x (M, R, D), roles (M, R), token_types (M, R)): tokens evaluated on their own
        (a single-token marginal query: its attention is its own value). They share every
        linear layer's matmul with the rows, which is what makes them cheap. Requires
        c_noise of shape (M, 1). Returns (rows_out, lone_out) when given, else rows_out.

        clean: (M, B, T) bool, row tokens given without noise (conditioning: observed nodes).
        They get a learned marker so the model can tell them from noisy ones.
        """
        m, b, t, d = x.shape
        tokens = x.to(self.enc_w.dtype).reshape(m, b * t, d)
        roles_flat, types_flat = roles.reshape(m, b * t), token_types.reshape(m, b * t)
        if lone is not None:
            if c_noise.shape[1] != 1:
                raise ValueError("lone tokens need one noise level per model (c_noise of shape (M, 1))")
            x_lone, roles_lone, types_lone = lone
            tokens = torch.cat([tokens, x_lone.to(tokens.dtype)], dim=1)
            roles_flat = torch.cat([roles_flat, roles_lone], dim=1)
            types_flat = torch.cat([types_flat, types_lone], dim=1)
        h = self._encode(tokens, roles_flat, types_flat)  # (M, N, H)
        if clean is not None:
            marker = clean.reshape(m, b * t, 1).to(h.dtype) * self.clean_emb.unsqueeze(1)  # (M, B*T, H)
            h = torch.cat([h[:, : b * t] + marker, h[:, b * t :]], dim=1)
        c = F.silu(self.noise_embedding(c_noise))  # (M, B or 1, H)
        attn_mask = present.reshape(m * b, 1, 1, t)  # True = attend
        for block in self.blocks:
            h = block(h, c, attn_mask, b, t)
        # Per-row levels (training): the modulation is computed once per row, then repeated
        # for the row's T tokens (computing it per token cost as much as the block itself).
        shift, scale = _per_token(_linear(c, self.final_mod_w, self.final_mod_b), t).chunk(2, dim=-1)
        h = F.layer_norm(h, (h.shape[-1],)) * (1 + scale) + shift
        out = self._decode(h, types_flat, d)  # (M, N, D)
        rows_out = out[:, : b * t].reshape(m, b, t, d)
        if lone is None:
            return rows_out
        return rows_out, out[:, b * t :]

    def _encode(self, tokens: torch.Tensor, roles: torch.Tensor, types: torch.Tensor) -> torch.Tensor:
        """(M, N, D) -> (M, N, H): every type's encoder (D is tiny), keep the token's own type,
        add the role embedding."""
        m, n, d = tokens.shape
        h_dim, n_types = self.config.hidden, len(TOKEN_TYPES)
        enc_w = self.enc_w.permute(0, 2, 1, 3).reshape(m, d, n_types * h_dim)  # (M, D, 3H)
        enc_b = self.enc_b.reshape(m, n_types * h_dim)
        h = _linear(tokens, enc_w, enc_b).reshape(m, n, n_types, h_dim)
        h = h.gather(2, types[..., None, None].expand(m, n, 1, h_dim)).squeeze(2)
        models = torch.arange(m, device=tokens.device).view(m, 1)
        return h + self.role_emb[models, roles]

    def _decode(self, h: torch.Tensor, types: torch.Tensor, d: int) -> torch.Tensor:
        m, n, h_dim = h.shape
        n_types = len(TOKEN_TYPES)
        dec_w = self.dec_w.permute(0, 2, 1, 3).reshape(m, h_dim, n_types * d)  # (M, H, 3D)
        dec_b = self.dec_b.reshape(m, n_types * d)
        out = _linear(h, dec_w, dec_b).reshape(m, n, n_types, d)
        return out.gather(2, types[..., None, None].expand(m, n, 1, d)).squeeze(2)

    @staticmethod
    def concatenate(stacks: list[DiTStack]) -> DiTStack:
        """One stack holding the models of several (same architecture), padded to the most tokens.

        Dropout is a training setting, not part of the architecture: models trained with
        different rates stack into a bank with dropout 0 (ADR 0004's sharp models train without)."""
        config = stacks[0].config
        if any(s.config.dropout != config.dropout for s in stacks):
            config = replace(config, dropout=0.0)
        for s in stacks:
            differing = [
                f"{k}: {v} vs {getattr(config, k)}"
                for k, v in s.config.to_dict().items()
                if k != "dropout" and v != getattr(config, k)
            ]
            if differing:
                raise ValueError(f"can only stack networks of one architecture ({'; '.join(differing)})")
        n_tokens = max(s.n_tokens for s in stacks)
        out = DiTStack(config, sum(s.n_models for s in stacks), n_tokens)
        with torch.no_grad():
            for name, param in out.named_parameters():
                parts: list[torch.Tensor] = []
                for s in stacks:
                    src: torch.Tensor = s.get_parameter(name)
                    if name == "role_emb" and src.shape[1] < n_tokens:
                        src = F.pad(src, (0, 0, 0, n_tokens - src.shape[1]))
                    parts.append(src)
                param.copy_(torch.cat(parts, dim=0))
        return out


class _Block(nn.Module):
    """adaLN-Zero transformer block (DiT) for M stacked models."""

    def __init__(self, m: int, h: int, mlp: int, heads: int, dropout: float) -> None:
        super().__init__()
        std = 0.02
        self.heads = heads
        self.dropout = dropout
        self.mod_w = _param(m, h, 6 * h)  # zero-initialised: each block starts as identity
        self.mod_b = _param(m, 6 * h)
        self.qkv_w = _param(m, h, 3 * h, std=std)
        self.qkv_b = _param(m, 3 * h)
        self.proj_w = _param(m, h, h, std=std)
        self.proj_b = _param(m, h)
        self.fc1_w = _param(m, h, mlp, std=std)
        self.fc1_b = _param(m, mlp)
        self.fc2_w = _param(m, mlp, h, std=std)
        self.fc2_b = _param(m, h)

    def forward(
        self, x: torch.Tensor, c: torch.Tensor, attn_mask: torch.Tensor, b: int, t: int
    ) -> torch.Tensor:
        """x: (M, N, H) with N = B*T row tokens, then any lone tokens; c: (M, 1 or B, H), one level per model or per row."""
        m, n, h = x.shape
        rows = b * t
        mod = _per_token(_linear(c, self.mod_w, self.mod_b), t)  # (M, 1 or N, 6H)
        shift1, scale1, gate1, shift2, scale2, gate2 = mod.chunk(6, dim=-1)
        p = self.dropout if self.training else 0.0

        y = F.layer_norm(x, (h,)) * (1 + scale1) + shift1
        qkv = _linear(y[:, :rows], self.qkv_w, self.qkv_b)  # (M, B*T, 3H)
        qkv = qkv.reshape(m * b, t, 3, self.heads, h // self.heads).permute(2, 0, 3, 1, 4)
        attn = F.scaled_dot_product_attention(qkv[0], qkv[1], qkv[2], attn_mask=attn_mask)
        attn = attn.transpose(1, 2).reshape(m, rows, h)  # (M, B*T, H)
        if n > rows:
            # A lone token attends only to itself: the softmax is 1 and attention returns V.
            lone_v = _linear(y[:, rows:], self.qkv_w[..., 2 * h :], self.qkv_b[..., 2 * h :])
            attn = torch.cat([attn, lone_v], dim=1)
        x = x + gate1 * F.dropout(_linear(attn, self.proj_w, self.proj_b), p, self.training)

        y = F.layer_norm(x, (h,)) * (1 + scale2) + shift2
        y = F.gelu(_linear(y, self.fc1_w, self.fc1_b))
        return x + gate2 * F.dropout(_linear(y, self.fc2_w, self.fc2_b), p, self.training)
