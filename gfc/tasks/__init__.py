"""Benchmark tasks: seeded scene samplers with hand-written reference actions.

``TASKS`` are the paper's four main tasks (what ``gfc sim bench`` and the simulator's tests
sweep); ``VARIANTS`` are the benchmark's harder versions of them (an interleaved skeleton, longer
horizons, other angles); ``SINGLE_ARM`` are the paper's single-arm tasks (STAP/GSC style: Hook
Reach, Rearrangement Push, Constrained Packing, variants T1-T3 each; docs/tasks_single_arm.md).
``sample_task`` knows them all; ``ALL_TASKS`` is their union.
"""

from __future__ import annotations

from gfc.tasks import (
    constrained_packing,
    hammer_nail,
    hammer_nail_extended,
    hammer_place,
    hammer_place_interleaved,
    hook_reach,
    pot_angles,
    pot_reorientation,
    pour_cup,
    rearrangement_push,
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

SINGLE_ARM: dict[str, Sampler] = {
    **{name: hook_reach.sampler(name) for name in hook_reach.VARIANTS},
    **{name: rearrangement_push.sampler(name) for name in rearrangement_push.VARIANTS},
    **{name: constrained_packing.sampler(name) for name in constrained_packing.VARIANTS},
}

ALL_TASKS: dict[str, Sampler] = {**TASKS, **VARIANTS, **SINGLE_ARM}


def sample_task(name: str, seed: int) -> TaskInstance:
    try:
        sampler = ALL_TASKS[name]
    except KeyError:
        raise KeyError(f"unknown task {name!r} (known: {', '.join(sorted(ALL_TASKS))})") from None
    return sampler(seed)


__all__ = ["ALL_TASKS", "SINGLE_ARM", "TASKS", "VARIANTS", "TaskInstance", "sample_task"]
