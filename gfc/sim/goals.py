"""Goal and constraint predicates evaluated on the simulated state (not on predicted nodes)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import torch

from gfc.constraints import footprint_separation
from gfc.geometry import FloatArray, matrix_to_pose9, pose7_to_matrix
from gfc.kinds import ObjectKind, object_kind
from gfc.plan.schema import Aligned, Apart, Far, FixedTransform, Inside, Near, SpatialFactorSpec, Yaw
from gfc.sim.panda import ee_matrix
from gfc.sim.world import World, object_matrix, yaw_of

Poses = Callable[[str], FloatArray]  # entity name -> world 4x4 (a robot: its end effector)
Kinds = Callable[[str], ObjectKind | None]  # entity name -> its object kind (None: a robot)


def entity_matrix(world: World, name: str) -> FloatArray:
    if name in world.physics.robots:
        return ee_matrix(world.client, world.physics.robots[name])
    return object_matrix(world.physics, name)


def _frame(poses: Poses, kinds: Kinds, name: str, frame: str | None) -> FloatArray:
    kind = kinds(name)
    base = poses(name)
    return base if kind is None else base @ pose7_to_matrix(kind.frame(frame))


def check_predicate(world: World, spec: SpatialFactorSpec) -> tuple[bool, str]:
    """Whether one predicate holds now in the simulator, and a line saying by how much."""
    return check_predicate_on(lambda name: entity_matrix(world, name), _world_kinds(world), spec)


def _world_kinds(world: World) -> Kinds:
    def kinds(name: str) -> ObjectKind | None:
        return None if name in world.physics.robots else object_kind(world.physics.objects[name].kind)

    return kinds


def check_predicate_on(poses: Poses, kinds: Kinds, spec: SpatialFactorSpec) -> tuple[bool, str]:
    """Whether one predicate holds for entities at ``poses``, and a line saying by how much.
    (The simulator's state, or a kinematic walk's: gfc/sim/screen.py.)"""
    if isinstance(spec, Inside):
        kind = kinds(spec.target)
        assert kind is not None and kind.inner_half_extents is not None
        local = np.linalg.inv(poses(spec.target)) @ poses(spec.object)[:, 3]
        half = np.asarray(kind.inner_half_extents)
        # The bottom centre must lie within the opening in xy and between the floor and the rim.
        inside_xy = bool(np.all(np.abs(local[:2]) <= half[:2] + spec.margin))
        inside_z = bool(-spec.margin <= local[2] <= 2 * half[2] + spec.margin)
        where = f"({local[0]:+.3f}, {local[1]:+.3f}, {local[2]:+.3f}) in {spec.target}"
        return inside_xy and inside_z, f"inside({spec.object}, {spec.target}): bottom at {where}"
    if isinstance(spec, Aligned):
        a = _frame(poses, kinds, spec.object, spec.frame)[:3, 3]
        b = _frame(poses, kinds, spec.target, spec.target_frame)[:3, 3]
        xy = float(np.linalg.norm(a[:2] - b[:2]))
        ok = abs(xy - spec.offset) <= spec.tolerance
        text = f"aligned({spec.object}, {spec.target}): {xy * 100:.1f} cm apart in xy"
        if spec.offset:
            text += f" (want {spec.offset * 100:.1f})"
        if spec.height is not None:
            dz = float(a[2] - b[2])
            ok = ok and abs(dz - spec.height) <= spec.tolerance
            text += f", {dz * 100:.1f} cm above (want {spec.height * 100:.1f})"
        return ok, text
    if isinstance(spec, Yaw):
        yaw = yaw_of(poses(spec.object))
        err = math.degrees(
            math.atan2(
                math.sin(yaw - math.radians(spec.yaw_deg)),
                math.cos(yaw - math.radians(spec.yaw_deg)),
            )
        )
        return (
            abs(err) <= spec.tolerance_deg,
            f"yaw({spec.object}) = {math.degrees(yaw):.1f} deg ({err:+.1f} off)",
        )
    if isinstance(spec, Near | Far):
        d = float(np.linalg.norm(poses(spec.object)[:3, 3] - poses(spec.target)[:3, 3]))
        ok = d <= spec.distance if isinstance(spec, Near) else d >= spec.distance
        return ok, f"{spec.type}({spec.object}, {spec.target}): {d:.3f} m (limit {spec.distance})"
    if isinstance(spec, FixedTransform):
        if spec.transform is None:
            return (
                True,
                "fixed_transform over several states is checked step by step, not at the end",
            )
        rel = np.linalg.inv(poses(spec.object)) @ poses(spec.target)
        d = float(np.linalg.norm(rel[:3, 3] - np.asarray(spec.transform[:3])))
        return (
            d <= spec.tolerance,
            f"fixed_transform({spec.object}, {spec.target}): {d * 100:.1f} cm off",
        )
    if isinstance(spec, Apart):
        kinds_of = [kinds(spec.object), kinds(spec.target)]
        assert kinds_of[0] is not None and kinds_of[1] is not None
        gap = footprint_gap(
            poses(spec.object), kinds_of[0].half_extents, poses(spec.target), kinds_of[1].half_extents
        )
        return (
            gap >= spec.clearance - APART_SLACK,
            f"apart({spec.object}, {spec.target}): footprints {gap * 100:.1f} cm apart "
            f"(want {spec.clearance * 100:.1f})",
        )
    raise TypeError(f"unknown predicate {spec!r}")


APART_SLACK = 0.002  # m: settled objects lean on each other by a millimetre or two


def footprint_gap(
    world_from_a: FloatArray, half_a: Sequence[float], world_from_b: FloatArray, half_b: Sequence[float]
) -> float:
    """How far apart two box footprints are (negative when they overlap): the planner's
    ``footprint_separation`` on simulator poses, so the goal check and the factor agree."""
    a, b = (
        torch.tensor(matrix_to_pose9(m), dtype=torch.float64).unsqueeze(0)
        for m in (world_from_a, world_from_b)
    )
    return float(footprint_separation(a, b, half_a, half_b))


def goal_satisfied(world: World, goal: list[SpatialFactorSpec]) -> tuple[bool, list[str]]:
    """All goal predicates that refer to the end state, checked in the simulator now."""
    return goal_satisfied_on(lambda name: entity_matrix(world, name), _world_kinds(world), goal)


def goal_satisfied_on(poses: Poses, kinds: Kinds, goal: list[SpatialFactorSpec]) -> tuple[bool, list[str]]:
    """``goal_satisfied`` for entities at ``poses`` (a kinematic walk's end state): whether all
    end-state predicates hold, and a line per predicate ("ok   " or "FAIL " first)."""
    report, ok = [], True
    for spec in goal:
        if spec.refs() != ["end"]:
            continue
        holds, text = check_predicate_on(poses, kinds, spec)
        ok = ok and holds
        report.append(("ok   " if holds else "FAIL ") + text)
    return ok, report
