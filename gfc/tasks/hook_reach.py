"""Hook Reach (STAP/GSC): a block lies on the table beyond the right arm's reach (0.82-0.87 m
from its base, where a top-down pick has no IK solution for its pre-grasp); the arm picks the hook, drags the
block into reach with ``pull``, lays the hook on its rack and picks the block.

- ``hook_reach_t1`` (4 steps): pick hook, pull block, place hook on the rack, pick block.
  Goal: the block is in the right hand (``near(block, right, 0.04)``: the grasp point is 2.5 cm
  above the block's bottom centre, and the pick only succeeds once the block rose with the hand).
- ``hook_reach_t2`` (5 steps): T1, then place the block in the box. Goal: ``inside(block, box)``.
- ``hook_reach_t3`` (8 steps): two far blocks, both pulled with one hold of the hook, then the
  hook goes on the rack and both blocks into the box. Goal: both ``inside`` the box.

The rack (fixed) runs along the table's x axis on the arm's outer side, clear of the blocks'
lanes; the box (fixed) sits between the arms, clear of the lanes too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gfc.geometry import FloatArray
from gfc.plan.schema import PlanRequest
from gfc.tasks.base import TABLE_Z, Sampler, TaskInstance, pose7, robots_json
from gfc.tasks.single_arm import (
    BOX_COLUMNS,
    ROBOT,
    block_grasp,
    block_in_box,
    hook_grasp,
    hook_on_rack,
    pick,
    place,
    stroke,
    tool,
)

HELD_DISTANCE = 0.04  # m between the hand and the block's bottom centre when it is held
PULL_TO_X = 0.58  # m (world x) where a pull leaves a block: well inside the arm's reach


@dataclass(frozen=True)
class Variant:
    blocks: int
    into_box: bool


VARIANTS: dict[str, Variant] = {
    "hook_reach_t1": Variant(blocks=1, into_box=False),
    "hook_reach_t2": Variant(blocks=1, into_box=True),
    "hook_reach_t3": Variant(blocks=2, into_box=True),
}

# Far blocks (world x, y): lanes 17 cm apart in y, so the hook's shaft (6.5 cm to a block's -y
# side while it pulls) never sweeps over the other block.
_FAR = ((0.83, -0.30), (0.85, -0.47))


def sample_variant(name: str, seed: int) -> TaskInstance:
    variant = VARIANTS[name]
    rng = np.random.default_rng(seed)
    blocks = ["block"] if variant.blocks == 1 else ["block_a", "block_b"]
    objects: list[dict[str, object]] = []
    block_at: list[tuple[float, float, float]] = []  # x, y, yaw
    for block, (x, y) in zip(blocks, _FAR, strict=False):
        at = (x + rng.uniform(-0.015, 0.015), y + rng.uniform(-0.02, 0.02), rng.uniform(-0.15, 0.15))
        block_at.append(at)
        objects.append({"name": block, "kind": "block", "pose": pose7(at[0], at[1], TABLE_Z, at[2])})
    hook_pose = pose7(
        0.38 + rng.uniform(-0.02, 0.02), -0.60 + rng.uniform(-0.02, 0.02), TABLE_Z, rng.uniform(-0.1, 0.1)
    )
    # The bar's near edge stays 3 cm or more from the hand's palm (which reaches 10 cm along the
    # fingers' axis, world y) while it grasps the hook; nearer, the palm caught on the bar.
    rack_yaw = math.pi / 2 + rng.uniform(-0.03, 0.03)
    rack_pose = pose7(0.56 + rng.uniform(-0.02, 0.02), -0.85 + rng.uniform(-0.01, 0.01), TABLE_Z, rack_yaw)
    objects += [
        {"name": "hook", "kind": "hook", "pose": hook_pose},
        {"name": "rack", "kind": "rack", "pose": rack_pose, "fixed": True},
    ]
    if variant.into_box:
        box_pose = pose7(
            0.45 + rng.uniform(-0.02, 0.02),
            -0.02 + rng.uniform(-0.02, 0.02),
            TABLE_Z,
            rng.uniform(-0.08, 0.08),
        )
        objects.append({"name": "box", "kind": "box", "pose": box_pose, "fixed": True})

    skeleton: list[dict[str, object]] = [pick("hook")]
    actions: list[FloatArray | None] = [hook_grasp()]
    for block, (bx, by, yaw) in zip(blocks, block_at, strict=True):
        skeleton.append(tool("pull", block))
        # Along the block's own x axis; its yaw (at most 0.15 rad) shortens the travel along world
        # x by 1 % at most.
        actions.append(stroke((bx, by), yaw, bx - PULL_TO_X, push=False))
    skeleton.append(place("hook", "rack"))
    actions.append(hook_on_rack())
    goal: list[dict[str, object]] = []
    slots = [0.0] if len(blocks) == 1 else list(BOX_COLUMNS)
    for block, slot in zip(blocks, slots, strict=True):
        skeleton.append(pick(block))
        actions.append(block_grasp())
        if variant.into_box:
            skeleton.append(place(block, "box"))
            actions.append(block_in_box(slot, 0.0))
            goal.append({"type": "inside", "object": block, "target": "box"})
        else:
            goal.append({"type": "near", "object": block, "target": ROBOT, "distance": HELD_DISTANCE})
    plan = PlanRequest.model_validate(
        {
            "scene": {"robots": robots_json(), "objects": objects},
            "skeleton": skeleton,
            "goal": goal,
            "options": {"seed": seed},
        }
    )
    return TaskInstance(name, seed, plan, actions)


def sampler(name: str) -> Sampler:
    if name not in VARIANTS:
        raise KeyError(f"unknown Hook Reach variant {name!r}")

    def sample(seed: int) -> TaskInstance:
        return sample_variant(name, seed)

    return sample
