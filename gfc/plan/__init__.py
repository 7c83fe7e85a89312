"""JSON plans: schema, compiler, compiled factor graph."""

from gfc.plan.compiler import PlanError, PlanIssue, compile_plan, load_plan, parse_plan
from gfc.plan.graph import CompiledPlan, NodeVersion, SpatialFactor, TemporalFactor
from gfc.plan.schema import PlanRequest

__all__ = [
    "CompiledPlan",
    "NodeVersion",
    "PlanError",
    "PlanIssue",
    "PlanRequest",
    "SpatialFactor",
    "TemporalFactor",
    "compile_plan",
    "load_plan",
    "parse_plan",
]
