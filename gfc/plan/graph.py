"""The compiled spatial-temporal factor graph: node versions, actions, temporal and spatial factors.

Plain frozen dataclasses (GTSAM style: factors hold keys and parameters, nothing else). The
planner turns them into index tensors; ``summary()`` is what ``gfc validate`` prints.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Literal

EntityType = Literal["robot", "object"]


@dataclass(frozen=True)
class NodeVersion:
    """One version of one entity: ``hammer@0`` before any skill, ``hammer@2`` after two."""

    id: int
    entity: str
    version: int
    entity_type: EntityType
    kind: str  # object kind, or "robot"
    dim: int
    known: bool
    value: tuple[float, ...] | None = None  # world-frame state of a known node
    written_by: tuple[int, ...] = ()  # step indices that produce this version

    @property
    def label(self) -> str:
        return f"{self.entity}@{self.version}"


@dataclass(frozen=True)
class ActionVariable:
    id: int
    step: int
    names: tuple[str, ...]

    @property
    def dim(self) -> int:
        return len(self.names)


@dataclass(frozen=True)
class FactorToken:
    """A token of a temporal factor: a node version (``node``) or the step's action."""

    role: str
    phase: Literal["pre", "action", "effect"]
    dim: int
    node: int | None = None
    action: int | None = None


@dataclass(frozen=True)
class TemporalFactor:
    """One skeleton step: the skill model's joint density over (pre nodes, action, effects)."""

    step: int
    skill: str
    model: str  # skill model reference: NAME[@VERSION|@ALIAS]
    robot: str
    group: str | None
    tokens: tuple[FactorToken, ...]
    world_from_model: tuple[tuple[float, ...], ...]  # 4x4: the acting robot's base frame

    @property
    def nodes(self) -> tuple[int, ...]:
        return tuple(t.node for t in self.tokens if t.node is not None)


@dataclass(frozen=True)
class SpatialFactor:
    """An energy over node versions: a user constraint or a goal predicate."""

    type: str
    source: Literal["constraint", "goal", "implied"]  # implied: physics, e.g. a two-handed grip
    index: int  # position in the request's constraints or goal list
    nodes: tuple[int, ...]
    params: dict[str, Any] = field(default_factory=dict)
    actions: tuple[int, ...] = ()  # action variables the residual reads after the nodes


@dataclass(frozen=True)
class CompiledPlan:
    nodes: tuple[NodeVersion, ...]
    actions: tuple[ActionVariable, ...]
    temporal: tuple[TemporalFactor, ...]
    spatial: tuple[SpatialFactor, ...]
    stages: tuple[tuple[int, ...], ...]  # steps that run together, in execution order
    terminal: tuple[tuple[int, str], ...] = ()  # (step, skill) of action-less steps with no factor

    @property
    def known(self) -> tuple[NodeVersion, ...]:
        return tuple(n for n in self.nodes if n.known)

    @property
    def free(self) -> tuple[NodeVersion, ...]:
        return tuple(n for n in self.nodes if not n.known)

    def node(self, label: str) -> NodeVersion:
        for n in self.nodes:
            if n.label == label:
                return n
        raise KeyError(f"no node version {label!r}")

    def temporal_degree(self) -> dict[int, int]:
        """How many temporal factors touch each node version."""
        counts: Counter[int] = Counter()
        for factor in self.temporal:
            counts.update(set(factor.nodes))
        return dict(counts)

    def summary(self) -> dict[str, Any]:
        degree = self.temporal_degree()
        label = {n.id: n.label for n in self.nodes}
        return {
            "node_versions": [n.label for n in self.nodes],
            "known_nodes": [n.label for n in self.known],
            "free_nodes": [n.label for n in self.free],
            "shared_nodes": sorted(label[i] for i, d in degree.items() if d >= 2),
            "actions": [{"step": a.step, "dim": a.dim} for a in self.actions],
            "temporal_factors": [
                {
                    "step": f.step,
                    "model": f.model,
                    "robot": f.robot,
                    "group": f.group,
                    "pre": [label[t.node] for t in f.tokens if t.phase == "pre" and t.node is not None],
                    "effect": [label[t.node] for t in f.tokens if t.phase == "effect" and t.node is not None],
                }
                for f in self.temporal
            ],
            "spatial_factors": [
                {
                    "type": s.type,
                    "source": s.source,
                    "index": s.index,
                    "nodes": [label[i] for i in s.nodes],
                    **({"actions_of_steps": [self.actions[a].step for a in s.actions]} if s.actions else {}),
                }
                for s in self.spatial
            ],
            "stages": [list(s) for s in self.stages],
        }
