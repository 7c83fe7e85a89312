"""Plan compiled factor graphs: sample candidates, rank them by constraint and goal satisfaction."""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import torch

from gfc.geometry import matrix_to_pose9, pose9_frame_map, pose9_to_matrix, pose9_to_pose7
from gfc.plan.graph import CompiledPlan, TemporalFactor
from gfc.plan.schema import Options
from gfc.planner.composed import Compensation, ComposedScore
from gfc.planner.layout import VariableLayout, known_values_of
from gfc.planner.library import SkillLibrary
from gfc.planner.merge import merge_plans
from gfc.planner.sampling import SamplingSettings, initial_noise, sample_graph
from gfc.planner.spatial import SpatialTerms
from gfc.skills.signatures import skill_spec

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


def batch_key(options: Options) -> tuple[Any, ...]:
    """Requests can share sampling steps when these agree."""
    return (options.steps, options.sampler, options.corrector_steps, options.compensation)


def effect_as_action(
    plan: CompiledPlan, factor: TemporalFactor, layout: VariableLayout, row: Any, raw: Any
) -> Any:
    """A move's parameter *is* its effect: the pose the held object (or the empty hand) ends at.
    Executing the sampled effect node (in the model's frame) rather than the action token makes
    the command agree with every factor on that node (the mug's rim over the cup, the pot at its
    target yaw), which the action token only follows through the model's learned, approximate
    identity; the simulator then derives the hand's pose from the grasp it really has."""
    effects = {t.role: t for t in factor.tokens if t.phase == "effect"}
    role = next((r for r in skill_spec(factor.skill).action_is_effect_of if r in effects), None)
    token = None if role is None else effects[role]
    if token is None or token.node is None or token.node not in layout.node_offset:
        return raw
    offset = layout.node_offset[token.node]
    world = row[offset : offset + 9]
    a, b = pose9_frame_map(np.asarray(factor.world_from_model))
    return a @ world + b


def describe_candidate(
    plan: CompiledPlan, spatial: SpatialTerms, z: torch.Tensor, index: int
) -> dict[str, Any]:
    """One sampled candidate as JSON: per step action, node poses, per factor residuals."""
    layout = spatial.layout
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
            raw = effect_as_action(plan, factor, layout, row, raw)
            vec = matrix_to_pose9(pose9_to_matrix(raw)) if var.dim == 9 else raw  # orthonormal rotation
            entry["action"] = [float(v) for v in vec]
            entry["action_named"] = dict(zip(var.names, entry["action"], strict=True))
            if var.dim == 9:
                entry["action_pose"] = [float(v) for v in pose9_to_pose7(vec)]
        steps.append(entry)
    steps += [{"step": i, "skill": skill, "model": None, "action": []} for i, skill in plan.terminal]
    steps.sort(key=lambda e: int(e["step"]))
    nodes: dict[str, Any] = {}
    for node in plan.free:
        o = layout.node_offset[node.id]
        vec = row[o : o + node.dim]
        info: dict[str, Any] = {"pose": [float(v) for v in pose9_to_pose7(vec[:9])]}
        if node.entity_type == "robot":
            info["gripper"] = float(vec[9])
        nodes[node.label] = info
    residuals = []
    for (spatial_factor, _), r in zip(spatial.factors, spatial.residuals(z[index : index + 1]), strict=True):
        worst = float(r.abs().max()) if r.numel() else 0.0
        residuals.append(
            {
                "type": spatial_factor.type,
                "source": spatial_factor.source,
                "index": spatial_factor.index,
                "max_scaled_residual": worst,
                "satisfied": worst <= SATISFIED_BELOW,
            }
        )
    return {"steps": steps, "nodes": nodes, "residuals": residuals}


def rank_candidates(
    plan: CompiledPlan, spatial: SpatialTerms, z: torch.Tensor, top_k: int
) -> list[dict[str, Any]]:
    cost = spatial.cost(z).detach()
    out = []
    for rank, i in enumerate(torch.argsort(cost, stable=True)[:top_k].tolist()):
        entry: dict[str, Any] = {"rank": rank, "cost": float(cost[i])}
        entry.update(describe_candidate(plan, spatial, z, i))
        out.append(entry)
    return out


def plan_candidates(
    plan: CompiledPlan,
    library: SkillLibrary,
    options: Options,
    settings: SamplingSettings | None = None,
    compensation: Compensation | None = None,
) -> PlanResult:
    """Sample ``options.candidates`` joint solutions and return the best ``options.top_k``."""
    return plan_many([(plan, options)], library, settings, compensation)[0]


def plan_many(
    requests: list[tuple[CompiledPlan, Options]],
    library: SkillLibrary,
    settings: SamplingSettings | None = None,
    compensation: Compensation | None = None,
) -> list[PlanResult]:
    """Plan several requests in one sampling run (one network call per step for all of them).

    They must agree on ``batch_key``. Each request draws its initial noise from its own seed,
    exactly as it would alone, and gets its own top-k, so batching does not change answers
    beyond floating-point rounding.
    """
    if not requests:
        return []
    keys = {batch_key(options) for _, options in requests}
    if len(keys) > 1:
        raise ValueError(f"requests differ in sampling settings and cannot share a batch: {sorted(keys)}")
    t0 = time.perf_counter()
    plans = [plan for plan, _ in requests]
    merged, columns = merge_plans(plans) if len(plans) > 1 else (plans[0], None)
    bank = library.bank([f.model for f in merged.temporal])
    first_options = requests[0][1]
    settings = settings or settings_from_options(first_options)
    composed = ComposedScore(merged, bank.denoiser, compensation=compensation or first_options.compensation)
    rows = max(options.candidates for _, options in requests)
    layouts = [VariableLayout.of(plan) for plan in plans]
    z0 = torch.zeros(rows, composed.layout.free_dim)
    known_noise = torch.zeros(rows, composed.layout.known_dim)
    sigma_max = settings.sigma_max
    for i, ((_, options), layout) in enumerate(zip(requests, layouts, strict=True)):
        z_i, noise_i = initial_noise(
            options.candidates, layout, sigma_max, torch.Generator().manual_seed(options.seed)
        )
        if columns is None:
            z0[: options.candidates], known_noise[: options.candidates] = z_i, noise_i
        else:
            z0[: options.candidates, columns[i].free] = z_i
            known_noise[: options.candidates, columns[i].known] = noise_i
    t1 = time.perf_counter()
    generator = torch.Generator().manual_seed(first_options.seed)  # only churn/correctors use it
    z = sample_graph(composed, rows, settings, generator, z0=z0, known_noise=known_noise)
    t2 = time.perf_counter()
    results = []
    for i, ((plan, options), layout) in enumerate(zip(requests, layouts, strict=True)):
        z_i = z[: options.candidates] if columns is None else z[: options.candidates, columns[i].free]
        spatial = SpatialTerms(plan, layout, known_values_of(plan, layout))
        candidates = rank_candidates(plan, spatial, z_i, options.top_k)
        versions = {f.model: bank.versions[f.model] for f in plan.temporal}
        results.append(PlanResult(candidates, versions))
    t3 = time.perf_counter()
    for result in results:
        result.timing = {
            "setup_s": t1 - t0,
            "sampling_s": t2 - t1,
            "ranking_s": t3 - t2,
            "total_s": t3 - t0,
            "batched_with": float(len(requests) - 1),
        }
    return results
