"""Pot Reorientation at other target angles, each registered as its own task.

``pot_reorientation`` itself turns the pot by 45 degrees. The reference actions reach from -45
to 60 degrees; 90 degrees is beyond the arms (the hands would cross: type 1), so it is not
registered as a task whose reference solves it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from gfc.tasks import pot_reorientation
from gfc.tasks.base import TaskInstance

ANGLES_DEG: dict[str, float] = {
    "pot_reorientation_-45": -45.0,
    "pot_reorientation_30": 30.0,
    "pot_reorientation_60": 60.0,
}


def sampler(name: str) -> Callable[[int], TaskInstance]:
    angle = ANGLES_DEG[name]

    def sample(seed: int) -> TaskInstance:
        return replace(pot_reorientation.sample_with_angle(seed, angle), task=name)

    return sample
