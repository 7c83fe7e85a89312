"""Benchmark tasks: seeded scene samplers with hand-written reference actions.

``TASKS`` are the paper's four main tasks (what ``gfc sim bench`` and the simulator's tests
sweep); ``VARIANTS`` are the benchmark's harder versions of them (an interleaved skeleton, longer
horizons, other angles). ``sample_task`` knows both; ``ALL_TASKS`` is their union.
"""

from __future__ import annotations

from gfc.tasks import (
    hammer_nail,
    hammer_nail_extended,
    hammer_place,
    hammer_place_interleaved,
    pot_angles,
    pot_reorientation,
    pour_cup,
)
from gfc.tasks.base import Sampler, TaskInstance

TASKS: dict[str, Sampler] = {
    "hammer_place": hammer_place.sample,
    "hammer_nail": hammer_nail.sample,
    "pot_reorientation": pot_reorientation.sample,
    "pour_cup": pour_cup.sample,
}

VARIANTS: dict[str, Sampler] = {
    "hammer_place_interleaved": hammer_place_interleaved.sample,
    **{name: hammer_nail_extended.sampler(name) for name in hammer_nail_extended.VARIANTS},
    **{name: pot_angles.sampler(name) for name in pot_angles.ANGLES_DEG},
}

ALL_TASKS: dict[str, Sampler] = {**TASKS, **VARIANTS}


def sample_task(name: str, seed: int) -> TaskInstance:
    try:
        sampler = ALL_TASKS[name]
    except KeyError:
        raise KeyError(f"unknown task {name!r} (known: {', '.join(sorted(ALL_TASKS))})") from None
    return sampler(seed)


__all__ = ["ALL_TASKS", "TASKS", "VARIANTS", "TaskInstance", "sample_task"]
