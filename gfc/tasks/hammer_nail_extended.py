"""Extended Hammer Nail (paper, appendix: longer horizons with more distractions): Hammer Nail
with extra pick-and-place steps of additional cubes that the right arm puts away into a crate on
its side of the table, before the hammer handover.

- ``hammer_nail_v1``: 16 steps (one cube picked, carried up and placed; one picked and placed)
- ``hammer_nail_v2``: 18 steps (as v1, plus a third cube picked and placed)
- ``hammer_nail_v3``: 20 steps (three cubes, each picked, carried up and placed)

The distractions go to the right arm because it is free until it takes the hammer (step 6 of
Hammer Nail) and its side of the table is empty in Hammer Nail; they sit between the lid-and-cube
prelude and the hammer steps. The base scene is exactly Hammer Nail's for the same seed (the extra
objects come from a second generator), so the variants differ from it only by the distractions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from gfc.geometry import FloatArray
from gfc.plan.schema import PlanRequest
from gfc.tasks import hammer_nail
from gfc.tasks.base import RIGHT_BASE, TABLE_Z, TaskInstance, frame, grasp9, in_base, pose7, rot_z
from gfc.tasks.boxes import FLOOR

PRELUDE_STEPS = 4  # the distractions go after Hammer Nail's lid-and-cube prelude
CUBE_GRASP_Z = 0.025  # from above, the cube's top half (as the prelude's cube)
CARRY_HEIGHT = 0.22  # m above the table while a cube is carried over the crate
# Slots along the crate's x axis: the fingers close along the cube's y axis, so a neighbour in
# the next slot (8 cm away) is never between them.
SLOTS = (-0.08, 0.0, 0.08)


@dataclass(frozen=True)
class Distraction:
    carry: bool  # pick, move (carry over the crate), place: 3 steps; else pick, place: 2


VARIANTS: dict[str, tuple[Distraction, ...]] = {
    "hammer_nail_v1": (Distraction(True), Distraction(False)),
    "hammer_nail_v2": (Distraction(True), Distraction(False), Distraction(False)),
    "hammer_nail_v3": (Distraction(True), Distraction(True), Distraction(True)),
}


def sample_variant(name: str, seed: int) -> TaskInstance:
    distractions = VARIANTS[name]
    base = hammer_nail.sample(seed)
    # A second stream, so Hammer Nail's own draws (and hence its scene) stay as they are.
    rng = np.random.default_rng([seed, 1])
    crate_x, crate_y = 0.50 + rng.uniform(-0.02, 0.02), -0.52 + rng.uniform(-0.02, 0.02)
    crate_yaw = rng.uniform(-0.1, 0.1)
    objects: list[dict[str, object]] = [
        {"name": "crate", "kind": "box", "pose": pose7(crate_x, crate_y, TABLE_Z, crate_yaw), "fixed": True}
    ]
    skeleton: list[dict[str, object]] = []
    actions: list[FloatArray | None] = []
    for i, distraction in enumerate(distractions):
        name_i = f"cube_{i}"
        # Cubes in a row in front of the crate, 12 cm apart, 17 cm or more from the nail.
        cx, cy = 0.40 + 0.12 * i + rng.uniform(-0.015, 0.015), -0.26 + rng.uniform(-0.015, 0.015)
        objects.append(
            {"name": name_i, "kind": "cube", "pose": pose7(cx, cy, TABLE_Z, rng.uniform(-0.3, 0.3))}
        )
        skeleton.append({"skill": "pick", "robot": "right", "object": name_i})
        actions.append(grasp9([0.0, 0.0, CUBE_GRASP_Z]))
        slot = SLOTS[i]
        if distraction.carry:
            skeleton.append({"skill": "move", "robot": "right", "object": name_i})
            crate = frame([crate_x, crate_y, TABLE_Z], rot_z(crate_yaw))
            cube_at = crate @ frame([slot, 0.0, CARRY_HEIGHT], np.eye(3))
            actions.append(in_base(RIGHT_BASE, cube_at))
        skeleton.append({"skill": "place", "robot": "right", "object": name_i, "target": "crate"})
        actions.append(grasp9([slot, 0.0, FLOOR + 0.003], np.eye(3)))

    data = base.plan.to_json_dict()
    data["scene"]["objects"] = [*data["scene"]["objects"], *objects]
    data["skeleton"] = [*data["skeleton"][:PRELUDE_STEPS], *skeleton, *data["skeleton"][PRELUDE_STEPS:]]
    reference = [
        *base.reference_actions[:PRELUDE_STEPS],
        *actions,
        *base.reference_actions[PRELUDE_STEPS:],
    ]
    return replace(base, task=name, plan=PlanRequest.model_validate(data), reference_actions=reference)


def sampler(name: str) -> Callable[[int], TaskInstance]:
    if name not in VARIANTS:
        raise KeyError(f"unknown Hammer Nail variant {name!r} (known: {', '.join(sorted(VARIANTS))})")

    def sample(seed: int) -> TaskInstance:
        return sample_variant(name, seed)

    return sample
