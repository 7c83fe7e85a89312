"""Where each variable of a compiled plan lives in the sampler's joint vectors."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from gfc.plan.graph import CompiledPlan, NodeVersion


@dataclass(frozen=True)
class VariableLayout:
    """Where each free node, action and known node lives in the joint vectors."""

    node_offset: dict[int, int]  # free node id -> offset in z
    action_offset: dict[int, int]  # action id -> offset in z
    known_offset: dict[int, int]  # known node id -> offset in the known vector
    free_dim: int
    known_dim: int

    @staticmethod
    def of(plan: CompiledPlan) -> VariableLayout:
        node_offset, action_offset, known_offset = {}, {}, {}
        free = known = 0
        for n in plan.nodes:
            if n.known:
                known_offset[n.id] = known
                known += n.dim
            else:
                node_offset[n.id] = free
                free += n.dim
        for a in plan.actions:
            action_offset[a.id] = free
            free += a.dim
        return VariableLayout(node_offset, action_offset, known_offset, free, known)

    def locate(self, node: NodeVersion) -> tuple[bool, int, int]:
        """(is known, offset in z or in the known vector, dim)."""
        if node.known:
            return True, self.known_offset[node.id], node.dim
        return False, self.node_offset[node.id], node.dim


def known_values_of(plan: CompiledPlan, layout: VariableLayout) -> torch.Tensor:
    """The observed values of the known nodes, concatenated. (K,)"""
    values = torch.zeros(layout.known_dim)
    for node in plan.known:
        assert node.value is not None
        o = layout.known_offset[node.id]
        values[o : o + node.dim] = torch.tensor(node.value)
    return values
