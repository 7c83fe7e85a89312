"""Several compiled plans as one factor graph (a disjoint union), to sample them together.

Concurrent requests then share every network call of a sampling step (the service's
micro-batching). Each plan keeps its own random stream, so its answer does not depend on what it
was batched with.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import torch

from gfc.plan.graph import (
    ActionVariable,
    CompiledPlan,
    FactorToken,
    NodeVersion,
    SpatialFactor,
    TemporalFactor,
)
from gfc.planner.layout import VariableLayout


@dataclass(frozen=True)
class PlanColumns:
    """Where one plan's own z and known vectors sit inside the merged ones."""

    free: torch.Tensor  # (N_i,) merged z column of each of the plan's z columns
    known: torch.Tensor  # (K_i,)


def merge_plans(plans: list[CompiledPlan]) -> tuple[CompiledPlan, list[PlanColumns]]:
    nodes: list[NodeVersion] = []
    actions: list[ActionVariable] = []
    temporal: list[TemporalFactor] = []
    spatial: list[SpatialFactor] = []
    stages: list[tuple[int, ...]] = []
    terminal: list[tuple[int, str]] = []
    node_base: list[int] = []
    action_base: list[int] = []
    for plan in plans:
        n0, a0 = len(nodes), len(actions)
        s0 = sum(len(stage) for stage in stages)  # steps so far (terminal steps have no factor)
        node_base.append(n0)
        action_base.append(a0)
        nodes += [replace(n, id=n.id + n0) for n in plan.nodes]
        actions += [ActionVariable(a.id + a0, a.step + s0, a.names) for a in plan.actions]
        for f in plan.temporal:
            tokens = tuple(
                FactorToken(
                    t.role,
                    t.phase,
                    t.dim,
                    node=None if t.node is None else t.node + n0,
                    action=None if t.action is None else t.action + a0,
                )
                for t in f.tokens
            )
            temporal.append(replace(f, step=f.step + s0, tokens=tokens))
        spatial += [
            replace(sf, nodes=tuple(n + n0 for n in sf.nodes), actions=tuple(a + a0 for a in sf.actions))
            for sf in plan.spatial
        ]
        stages += [tuple(i + s0 for i in stage) for stage in plan.stages]
        terminal += [(i + s0, skill) for i, skill in plan.terminal]
    merged = CompiledPlan(
        tuple(nodes), tuple(actions), tuple(temporal), tuple(spatial), tuple(stages), tuple(terminal)
    )
    merged_layout = VariableLayout.of(merged)
    columns = []
    for plan, n0, a0 in zip(plans, node_base, action_base, strict=True):
        layout = VariableLayout.of(plan)
        free = torch.empty(layout.free_dim, dtype=torch.long)
        known = torch.empty(layout.known_dim, dtype=torch.long)
        for node in plan.nodes:
            if node.known:
                o, m = layout.known_offset[node.id], merged_layout.known_offset[node.id + n0]
                known[o : o + node.dim] = torch.arange(m, m + node.dim)
            else:
                o, m = layout.node_offset[node.id], merged_layout.node_offset[node.id + n0]
                free[o : o + node.dim] = torch.arange(m, m + node.dim)
        for action in plan.actions:
            o, m = layout.action_offset[action.id], merged_layout.action_offset[action.id + a0]
            free[o : o + action.dim] = torch.arange(m, m + action.dim)
        columns.append(PlanColumns(free, known))
    return merged, columns
