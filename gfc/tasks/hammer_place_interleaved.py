"""Hammer Place with an inconsistent skeleton (paper: the same 8 steps, independent sub-tasks
interleaved): the left arm takes the lid off and hands the hammer to the right arm *before* it
moves the cube, and the right arm holds the hammer until the very end.

Holding rules decide the interleaving: the left arm holds one thing at a time, so the hammer
steps can only start once the lid is down, and the cube can only be picked once the right arm has
taken the hammer. The scene and every reference action are Hammer Place's (same seed, same
scene), only their order changes, so the two tasks differ in nothing but the skeleton.
"""

from __future__ import annotations

from dataclasses import replace

from gfc.plan.schema import PlanRequest
from gfc.tasks import hammer_place
from gfc.tasks.base import TaskInstance

# Position of each interleaved step in Hammer Place's skeleton:
# pick lid, place lid, pick hammer, move hammer, regrasp hammer, pick cube, place cube, place hammer.
ORDER = (0, 1, 4, 5, 6, 2, 3, 7)


def sample(seed: int) -> TaskInstance:
    base = hammer_place.sample(seed)
    data = base.plan.to_json_dict()
    data["skeleton"] = [data["skeleton"][i] for i in ORDER]
    plan = PlanRequest.model_validate(data)
    actions = [base.reference_actions[i] for i in ORDER]
    return replace(base, task="hammer_place_interleaved", plan=plan, reference_actions=actions)
