"""Plan a compiled factor graph: sample candidates, rank them by constraint and goal satisfaction."""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import torch

from gfc.geometry import matrix_to_pose9, pose9_to_matrix, pose9_to_pose7
from gfc.plan.graph import CompiledPlan
from gfc.plan.schema import Options
from gfc.planner.composed import Compensation, ComposedScore
from gfc.planner.library import SkillLibrary
from gfc.planner.sampling import SamplingSettings, sample_graph

SATISFIED_BELOW = 1.0  # a factor is satisfied when every scaled residual is within its tolerance


@dataclass
class PlanResult:
    candidates: list[dict[str, Any]]
    models: dict[str, str]  # model reference -> resolved version
    timing: dict[str, float] = field(default_factory=dict)


def settings_from_options(options: Options, **overrides: Any) -> SamplingSettings:
    base = SamplingSettings(
        steps=options.steps, sampler=options.sampler, corrector_steps=options.corrector_steps
    )
    return replace(base, **overrides)


def _orthonormalised(vec: np.ndarray) -> np.ndarray:
    """A 9-vector pose with its rotation columns made orthonormal (what an executor can use)."""
    return matrix_to_pose9(pose9_to_matrix(vec))


def describe_candidate(composed: ComposedScore, z: torch.Tensor, index: int) -> dict[str, Any]:
    """One sampled candidate as JSON: per step action, node poses, per factor residuals."""
    plan = composed.plan
    layout = composed.layout
    row = z[index].double().numpy()
    steps = []
    for factor in plan.temporal:
        action = next((t.action for t in factor.tokens if t.action is not None), None)
        entry: dict[str, Any] = {"step": factor.step, "skill": factor.skill, "model": factor.model}
        if action is None:
            entry["action"] = []
        else:
            var = plan.actions[action]
            raw = row[layout.action_offset[action] : layout.action_offset[action] + var.dim]
            vec = _orthonormalised(raw) if var.dim == 9 else raw
            entry["action"] = [float(v) for v in vec]
            entry["action_named"] = dict(zip(var.names, entry["action"], strict=True))
            if var.dim == 9:
                entry["action_pose"] = [float(v) for v in pose9_to_pose7(vec)]
        steps.append(entry)
    nodes: dict[str, Any] = {}
    for node in plan.free:
        o = layout.node_offset[node.id]
        vec = row[o : o + node.dim]
        info: dict[str, Any] = {"pose": [float(v) for v in pose9_to_pose7(vec[:9])]}
        if node.entity_type == "robot":
            info["gripper"] = float(vec[9])
        nodes[node.label] = info
    residuals = []
    for (spatial, _), r in zip(
        composed._spatial, composed.spatial_residuals(z[index : index + 1]), strict=True
    ):
        worst = float(r.abs().max()) if r.numel() else 0.0
        residuals.append(
            {
                "type": spatial.type,
                "source": spatial.source,
                "index": spatial.index,
                "max_scaled_residual": worst,
                "satisfied": worst <= SATISFIED_BELOW,
            }
        )
    return {"steps": steps, "nodes": nodes, "residuals": residuals}


def plan_candidates(
    plan: CompiledPlan,
    library: SkillLibrary,
    options: Options,
    settings: SamplingSettings | None = None,
    compensation: Compensation | None = None,
) -> PlanResult:
    """Sample ``options.candidates`` joint solutions and return the best ``options.top_k``."""
    t0 = time.perf_counter()
    bank = library.bank([f.model for f in plan.temporal])
    composed = ComposedScore(plan, bank.denoiser, compensation=compensation or options.compensation)
    t1 = time.perf_counter()
    generator = torch.Generator().manual_seed(options.seed)
    z = sample_graph(composed, options.candidates, settings or settings_from_options(options), generator)
    t2 = time.perf_counter()
    cost = composed.spatial_cost(z).detach()
    order = torch.argsort(cost, stable=True)[: options.top_k]
    candidates = []
    for rank, i in enumerate(order.tolist()):
        entry = {"rank": rank, "cost": float(cost[i])}
        entry.update(describe_candidate(composed, z, i))
        candidates.append(entry)
    t3 = time.perf_counter()
    timing = {"setup_s": t1 - t0, "sampling_s": t2 - t1, "ranking_s": t3 - t2, "total_s": t3 - t0}
    return PlanResult(candidates, bank.versions, timing)
