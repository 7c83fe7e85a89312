"""Rearrangement Push (STAP/GSC): a rack (a bar on two legs, fixed) stands in front of the right
arm; the arm places the block in front of the rack, picks the hook and pushes the block under
the rack's bar with ``push``.

- ``rearrangement_push_t1`` (4 steps): pick block, place block in front of the rack (a placement
  in the rack's frame), pick hook, push block.
- ``rearrangement_push_t2`` (6 steps): a second block stands on the spot in front of the rack;
  the arm first puts it in the box (pick, place), then T1.
- ``rearrangement_push_t3`` (8 steps): two blocks stand in the push lane (on the spot, and 9 cm
  nearer the robot, where the hook is lowered for the push); both go into the box first.

Goal: ``aligned(block, rack, tolerance=0.04)``: the block's centre within 4 cm (in xy) of the
rack's centre, so under the 10 cm wide bar (``inside`` needs a container; the rack is none). The
cleared blocks must be ``inside`` the box. The push is the only step that can bring the block
there: the placement leaves it 13 cm in front of the rack's centre (a test checks both).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gfc.geometry import FloatArray
from gfc.plan.schema import PlanRequest
from gfc.tasks.base import TABLE_Z, Sampler, TaskInstance, frame, grasp9, pose7, robots_json, rot_z
from gfc.tasks.single_arm import (
    BOX_COLUMNS,
    block_grasp,
    block_in_box,
    hook_grasp,
    pick,
    place,
    stroke,
    tool,
)

UNDER_RACK_TOLERANCE = 0.04  # m: the block's centre within the bar's 10 cm width
FRONT_OF_RACK = -0.13  # rack-frame x where the block is placed, 5.5 cm clear of the bar
# Rack-frame x of the blocks that stand in the way: on the spot, and where the hook comes down.
IN_THE_WAY = (FRONT_OF_RACK, -0.22)


@dataclass(frozen=True)
class Variant:
    in_the_way: int  # blocks to clear into the box before the push


VARIANTS: dict[str, Variant] = {
    "rearrangement_push_t1": Variant(0),
    "rearrangement_push_t2": Variant(1),
    "rearrangement_push_t3": Variant(2),
}


def sample_variant(name: str, seed: int) -> TaskInstance:
    variant = VARIANTS[name]
    rng = np.random.default_rng(seed)
    rx, ry, ryaw = (
        0.78 + rng.uniform(-0.015, 0.015),
        -0.32 + rng.uniform(-0.02, 0.02),
        rng.uniform(-0.05, 0.05),
    )
    objects: list[dict[str, object]] = [
        {"name": "rack", "kind": "rack", "pose": pose7(rx, ry, TABLE_Z, ryaw), "fixed": True},
        {
            "name": "block",
            "kind": "block",
            "pose": pose7(
                0.45 + rng.uniform(-0.02, 0.02),
                -0.56 + rng.uniform(-0.02, 0.02),
                TABLE_Z,
                rng.uniform(-0.3, 0.3),
            ),
        },
        {
            "name": "hook",
            "kind": "hook",
            "pose": pose7(
                0.38 + rng.uniform(-0.02, 0.02),
                -0.72 + rng.uniform(-0.01, 0.01),
                TABLE_Z,
                rng.uniform(-0.08, 0.08),
            ),
        },
    ]
    skeleton: list[dict[str, object]] = []
    actions: list[FloatArray | None] = []
    goal: list[dict[str, object]] = [
        {"type": "aligned", "object": "block", "target": "rack", "tolerance": UNDER_RACK_TOLERANCE}
    ]
    if variant.in_the_way:
        box_yaw = rng.uniform(-0.08, 0.08)
        box_pose = pose7(0.42 + rng.uniform(-0.02, 0.02), 0.03 + rng.uniform(-0.02, 0.02), TABLE_Z, box_yaw)
        objects.append({"name": "box", "kind": "box", "pose": box_pose, "fixed": True})
        world_from_rack = frame([rx, ry, TABLE_Z], rot_z(ryaw))
        for i, (x, slot) in enumerate(zip(IN_THE_WAY[: variant.in_the_way], BOX_COLUMNS, strict=False)):
            obstacle = f"obstacle_{i}"
            at = world_from_rack @ np.array(
                [x + rng.uniform(-0.01, 0.01), rng.uniform(-0.015, 0.015), 0.0, 1.0]
            )
            objects.append(
                {
                    "name": obstacle,
                    "kind": "block",
                    "pose": pose7(float(at[0]), float(at[1]), TABLE_Z, ryaw + rng.uniform(-0.3, 0.3)),
                }
            )
            skeleton += [pick(obstacle), place(obstacle, "box")]
            actions += [block_grasp(), block_in_box(slot, 0.0)]
            goal.append({"type": "inside", "object": obstacle, "target": "box"})
    skeleton += [pick("block"), place("block", "rack"), pick("hook"), tool("push", "block")]
    front_of_rack = frame([rx, ry, TABLE_Z], rot_z(ryaw)) @ np.array([FRONT_OF_RACK, 0.0, 0.0, 1.0])
    actions += [
        block_grasp(),
        grasp9([FRONT_OF_RACK, 0.0, 0.003], np.eye(3)),  # on the table, square to the bar (rack frame)
        hook_grasp(),
        # From 13 cm in front of the bar to its centre line, square to the bar.
        stroke(front_of_rack[:2], ryaw, -FRONT_OF_RACK, push=True),
    ]
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
        raise KeyError(f"unknown Rearrangement Push variant {name!r}")

    def sample(seed: int) -> TaskInstance:
        return sample_variant(name, seed)

    return sample
