"""``PlanBuilder``: write a plan's scene, skeleton, constraints and goal as a chain of calls.

::

    plan = (
        PlanBuilder()
        .robot("left", base=(0.0, 0.35, 0.625))
        .robot("right", base=(0.0, -0.35, 0.625))
        .object("hammer", kind="hammer", pose=(0.45, 0.25, 0.64))
        .object("box", kind="box", pose=(0.45, -0.40, 0.625), fixed=True)
        .pick("left", "hammer")
        .move("left", "hammer")
        .handover("hammer", giver="left", receiver="right")
        .place("right", "hammer", target="box")
        .goal.inside("hammer", "box")
        .build()
    )

Names are checked as you go (a step that names an unknown robot or object fails at once); the
service checks the rest (who holds what) and answers 422 with the location of each problem.
"""

from __future__ import annotations

import copy
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

Ref = int | str | Sequence[int | str]
"""A point in the plan: a step index, a group name, "start" or "end" (or a list of them)."""


def _pose(pose: Sequence[float], what: str) -> list[float]:
    values = [float(v) for v in pose]
    if len(values) == 3:
        return [*values, 0.0, 0.0, 0.0, 1.0]  # upright: the identity quaternion
    if len(values) == 7:
        return values
    raise ValueError(f"{what}: a pose is [x, y, z] or [x, y, z, qx, qy, qz, qw], got {len(values)} numbers")


class _Factors:
    """Spatial factors for ``constraints`` or ``goal``; each method returns the builder."""

    def __init__(self, builder: PlanBuilder, entries: list[dict[str, Any]]) -> None:
        self._builder = builder
        self._entries = entries

    def add(
        self, factor_type: str, *, at: Ref = "end", weight: float | None = None, **fields: Any
    ) -> PlanBuilder:
        """Any factor type by name (``inside``, ``aligned``, ``fixed_transform``, ``yaw``, ...)."""
        for key in ("object", "target"):
            if key in fields:
                self._builder._require_entity(fields[key], f"{factor_type}.{key}")
        entry: dict[str, Any] = {"type": factor_type, **{k: v for k, v in fields.items() if v is not None}}
        entry["at"] = list(at) if isinstance(at, Sequence) and not isinstance(at, str) else at
        if weight is not None:
            entry["weight"] = weight
        self._entries.append(entry)
        return self._builder

    def inside(
        self, object: str, target: str, *, margin: float | None = None, at: Ref = "end"
    ) -> PlanBuilder:
        """``object`` rests inside ``target``'s open region."""
        return self.add("inside", object=object, target=target, margin=margin, at=at)

    def aligned(
        self,
        object: str,
        target: str,
        *,
        frame: str | None = None,
        target_frame: str | None = None,
        height: float | None = None,
        offset: float | None = None,
        tolerance: float | None = None,
        at: Ref = "end",
    ) -> PlanBuilder:
        """A frame of ``object`` lies over a frame of ``target`` (optionally ``height`` above, and
        ``offset`` metres from it horizontally)."""
        return self.add(
            "aligned",
            object=object,
            target=target,
            frame=frame,
            target_frame=target_frame,
            height=height,
            offset=offset,
            tolerance=tolerance,
            at=at,
        )

    def fixed_transform(
        self,
        object: str,
        target: str,
        *,
        transform: Sequence[float] | None = None,
        tolerance: float | None = None,
        at: Ref = "end",
    ) -> PlanBuilder:
        """``target``'s pose relative to ``object`` stays the same at every state in ``at``."""
        pose = None if transform is None else _pose(transform, "fixed_transform.transform")
        return self.add(
            "fixed_transform", object=object, target=target, transform=pose, tolerance=tolerance, at=at
        )

    def yaw(
        self, object: str, degrees: float, *, tolerance_deg: float | None = None, at: Ref = "end"
    ) -> PlanBuilder:
        return self.add("yaw", object=object, yaw_deg=degrees, tolerance_deg=tolerance_deg, at=at)

    def near(self, object: str, target: str, distance: float, *, at: Ref = "end") -> PlanBuilder:
        return self.add("near", object=object, target=target, distance=distance, at=at)

    def far(self, object: str, target: str, distance: float, *, at: Ref = "end") -> PlanBuilder:
        return self.add("far", object=object, target=target, distance=distance, at=at)

    def apart(
        self, object: str, target: str, *, clearance: float | None = None, at: Ref = "end"
    ) -> PlanBuilder:
        """The two objects' footprints do not overlap and keep ``clearance`` (m) between them."""
        return self.add("apart", object=object, target=target, clearance=clearance, at=at)


class PlanBuilder:
    def __init__(self) -> None:
        self._robots: list[dict[str, Any]] = []
        self._objects: list[dict[str, Any]] = []
        self._skeleton: list[dict[str, Any]] = []
        self._constraints: list[dict[str, Any]] = []
        self._goal: list[dict[str, Any]] = []
        self._options: dict[str, Any] = {}
        self._group: str | None = None
        self.constraint = _Factors(self, self._constraints)
        """Constraints: ``.constraint.aligned(..., at="align")``; default ``at`` is the end."""
        self.goal = _Factors(self, self._goal)
        """Goal terms, which hold at the end: ``.goal.inside("hammer", "box")``."""

    # ---- scene ---------------------------------------------------------------------------
    def robot(
        self,
        name: str,
        *,
        base: Sequence[float],
        yaw: float = 0.0,
        ee_pose: Sequence[float] | None = None,
        gripper: float | None = None,
    ) -> PlanBuilder:
        """A robot arm with its base at ``base`` [x, y, z] and heading ``yaw`` (radians)."""
        self._unique(name)
        if len(base) != 3:
            raise ValueError(f"robot {name!r}: base is [x, y, z], got {list(base)}")
        robot: dict[str, Any] = {"name": name, "base": [float(v) for v in base]}
        if yaw:
            robot["yaw"] = float(yaw)
        if ee_pose is not None:
            robot["ee_pose"] = _pose(ee_pose, f"robot {name!r} ee_pose")
        if gripper is not None:
            robot["gripper"] = float(gripper)
        self._robots.append(robot)
        return self

    def object(self, name: str, *, kind: str, pose: Sequence[float], fixed: bool = False) -> PlanBuilder:
        """An object of ``kind`` (hammer, box, ...) at ``pose``; ``fixed`` ones never move."""
        self._unique(name)
        entry: dict[str, Any] = {"name": name, "kind": kind, "pose": _pose(pose, f"object {name!r}")}
        if fixed:
            entry["fixed"] = True
        self._objects.append(entry)
        return self

    # ---- skeleton ------------------------------------------------------------------------
    def step(
        self,
        skill: str,
        robot: str,
        object: str | None = None,
        *,
        target: str | None = None,
        from_: str | None = None,
        group: str | None = None,
        model: str | None = None,
    ) -> PlanBuilder:
        """Any skill by name (``strike``, ``pour``, ...). ``model`` pins NAME[@VERSION|@ALIAS]."""
        self._require(robot, self._robots, "robot", f"skeleton[{len(self._skeleton)}].robot")
        entry: dict[str, Any] = {"skill": skill, "robot": robot}
        for key, value in (("object", object), ("target", target), ("from", from_)):
            if value is not None:
                self._require_entity(value, f"skeleton[{len(self._skeleton)}].{key}")
                entry[key] = value
        group = group or self._group
        if group is not None:
            entry["group"] = group
        if model is not None:
            entry["model"] = model
        self._skeleton.append(entry)
        return self

    def pick(
        self, robot: str, object: str, *, group: str | None = None, model: str | None = None
    ) -> PlanBuilder:
        return self.step("pick", robot, object, group=group, model=model)

    def move(
        self, robot: str, object: str, *, group: str | None = None, model: str | None = None
    ) -> PlanBuilder:
        """Move the held ``object`` to a new pose (the planner samples it)."""
        return self.step("move", robot, object, group=group, model=model)

    def place(
        self, robot: str, object: str, *, target: str, group: str | None = None, model: str | None = None
    ) -> PlanBuilder:
        return self.step("place", robot, object, target=target, group=group, model=model)

    def handover(
        self, object: str, *, giver: str, receiver: str, group: str | None = None, model: str | None = None
    ) -> PlanBuilder:
        """``receiver`` takes ``object`` from ``giver`` (the ``regrasp`` skill)."""
        return self.step("regrasp", receiver, object, from_=giver, group=group, model=model)

    @contextmanager
    def group(self, name: str) -> Iterator[PlanBuilder]:
        """Steps added inside ``with builder.group("align"):`` run at the same time; constraints
        can then refer to the state after them with ``at="align"``."""
        if self._group is not None:
            raise ValueError(f"group {name!r} inside group {self._group!r}: groups do not nest")
        self._group = name
        try:
            yield self
        finally:
            self._group = None

    # ---- options and result --------------------------------------------------------------
    def options(self, **options: Any) -> PlanBuilder:
        """Sampling options: candidates, top_k, steps, seed, sampler, compensation, corrector_steps."""
        self._options.update(options)
        return self

    def build(self) -> dict[str, Any]:
        """The plan JSON, ready for ``Client.plan`` (a fresh copy each time)."""
        if not self._robots:
            raise ValueError("a plan needs at least one robot: add one with .robot(name, base=...)")
        if not self._skeleton:
            raise ValueError("a plan needs at least one step: add one with .pick(...), .move(...), ...")
        plan: dict[str, Any] = {
            "scene": {"robots": self._robots, "objects": self._objects},
            "skeleton": self._skeleton,
            "constraints": self._constraints,
            "goal": self._goal,
        }
        if self._options:
            plan["options"] = self._options
        return copy.deepcopy(plan)

    # ---- checks --------------------------------------------------------------------------
    def _unique(self, name: str) -> None:
        if any(e["name"] == name for e in (*self._robots, *self._objects)):
            raise ValueError(f"{name!r} is already in the scene; robot and object names must be unique")

    def _require(self, name: str, entries: list[dict[str, Any]], what: str, loc: str) -> None:
        if not any(e["name"] == name for e in entries):
            known = ", ".join(e["name"] for e in entries) or "none yet"
            raise ValueError(f"{loc}: no {what} named {name!r} (known: {known}); add it with .{what}(...)")

    def _require_entity(self, name: str, loc: str) -> None:
        self._require(name, [*self._robots, *self._objects], "object", loc)
