"""Uniform random skill parameters: the ``random`` baseline of the task benchmark.

Each step's action is drawn uniformly from a box in the frame the action is expressed in
(``gfc.skills.signatures``), so the baseline knows the action spaces but nothing learned:

- ``pick``, ``regrasp``: grasp pose in the object frame; position in the object's bounding box
  grown by ``GRASP_MARGIN`` on every side (the frame is the bottom face's centre, so z runs from
  ``-margin`` to the object's height + margin).
- ``place``: object pose in the target frame; position over the target's footprint, up to
  ``PLACE_ABOVE`` over its top.
- ``move``: pose of the held object (the hand when empty) in the acting robot's base frame; position in ``WORKSPACE``, the
  region in front of a Panda that the tasks use.
- ``push``, ``pull``: ``(x, y, r, theta)`` uniform in ``PUSH_LOW``..``PUSH_HIGH`` (the executor
  accepts ``0 < r <= 0.3``).
- ``strike``, ``pour``: no action (``None``).

Rotations are uniform on SO(3) (a normalised 4-D Gaussian is a uniform unit quaternion), so the
9-D actions have orthonormal rotation columns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gfc.geometry import FloatArray, quat_to_matrix
from gfc.kinds import object_kind
from gfc.plan.schema import PlanRequest, Step
from gfc.skills.signatures import skill_spec

GRASP_MARGIN = 0.02  # m around an object's box: a grasp point 1 cm off the object still counts
PLACE_ABOVE = 0.10  # m over the target's top
WORKSPACE = ((0.20, -0.50, 0.00), (0.80, 0.50, 0.50))  # base frame (base on the table top)
PUSH_LOW = (-0.25, -0.25, 0.01, -math.pi)
PUSH_HIGH = (0.25, 0.25, 0.30, math.pi)


@dataclass(frozen=True)
class ActionBox:
    """Where a step's uniform action lives: a position box (9-D pose actions, any rotation) or
    the whole action's box (4-D push/pull)."""

    low: tuple[float, ...]
    high: tuple[float, ...]
    pose: bool  # True: low/high bound the position of a 9-D pose action

    def __post_init__(self) -> None:
        if len(self.low) != len(self.high) or any(h < lo for lo, h in zip(self.low, self.high, strict=True)):
            raise ValueError(f"not a box: low {self.low}, high {self.high}")


def random_rotation(rng: np.random.Generator) -> FloatArray:
    """A rotation matrix drawn uniformly from SO(3) (Haar measure)."""
    while True:
        q = rng.standard_normal(4)
        if np.linalg.norm(q) > 1e-6:  # the normalisation needs a nonzero vector
            return quat_to_matrix(q)


def uniform_pose9(rng: np.random.Generator, low: tuple[float, ...], high: tuple[float, ...]) -> FloatArray:
    """A 9-D pose action: position uniform in the box, rotation uniform on SO(3)."""
    position = rng.uniform(np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64))
    rotation = random_rotation(rng)
    return np.concatenate([position, rotation[:, 0], rotation[:, 1]])


def uniform_box(rng: np.random.Generator, low: tuple[float, ...], high: tuple[float, ...]) -> FloatArray:
    """An action uniform in an axis-aligned box (push/pull parameters)."""
    return rng.uniform(np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64))


def _kind_box(kind: str, margin: float, above: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    hx, hy, hz = object_kind(kind).half_extents
    return (-hx - margin, -hy - margin, -margin), (hx + margin, hy + margin, 2 * hz + margin + above)


def action_box(plan: PlanRequest, step: Step) -> ActionBox | None:
    """The box the ``random`` baseline draws this step's action from; ``None`` for action-less
    skills."""
    spec = skill_spec(step.skill)
    if spec.action_dim == 0:
        return None
    kinds = {o.name: o.kind for o in plan.scene.objects}
    if step.skill in ("push", "pull"):
        return ActionBox(PUSH_LOW, PUSH_HIGH, pose=False)
    if spec.action_dim != 9:
        raise ValueError(f"no uniform sampler for {step.skill!r} ({spec.action_dim}-D actions)")
    if step.skill in ("pick", "regrasp"):
        assert step.object is not None  # the compiler requires it
        low, high = _kind_box(kinds[step.object], GRASP_MARGIN, 0.0)
    elif step.skill == "place":
        assert step.target is not None
        low, high = _kind_box(kinds[step.target], 0.0, PLACE_ABOVE)
        if kinds[step.target] == "rack":  # things go in front of and beside the rack, not on it
            low, high = (low[0] - 0.2, low[1] - 0.2, low[2]), (high[0] + 0.2, high[1] + 0.2, high[2])
    else:  # move: the held object (or the hand) anywhere in front of the robot
        low, high = WORKSPACE
    return ActionBox(low, high, pose=True)


def uniform_action(rng: np.random.Generator, box: ActionBox | None) -> FloatArray | None:
    if box is None:
        return None
    return uniform_pose9(rng, box.low, box.high) if box.pose else uniform_box(rng, box.low, box.high)


def random_actions(plan: PlanRequest, rng: np.random.Generator) -> list[FloatArray | None]:
    """One uniform action per skeleton step (``None`` where the skill takes none)."""
    return [uniform_action(rng, action_box(plan, step)) for step in plan.skeleton]
