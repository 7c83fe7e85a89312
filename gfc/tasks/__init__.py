"""Benchmark tasks: seeded scene samplers with hand-written reference actions."""

from __future__ import annotations

from gfc.tasks import hammer_nail, hammer_place, pot_reorientation, pour_cup
from gfc.tasks.base import Sampler, TaskInstance

TASKS: dict[str, Sampler] = {
    "hammer_place": hammer_place.sample,
    "hammer_nail": hammer_nail.sample,
    "pot_reorientation": pot_reorientation.sample,
    "pour_cup": pour_cup.sample,
}


def sample_task(name: str, seed: int) -> TaskInstance:
    try:
        sampler = TASKS[name]
    except KeyError:
        raise KeyError(f"unknown task {name!r} (known: {', '.join(sorted(TASKS))})") from None
    return sampler(seed)


__all__ = ["TASKS", "TaskInstance", "sample_task"]
