"""Shared helpers for the simulator tests."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from gfc.plan.schema import PlanRequest
from gfc.sim.world import World, build_world
from gfc.tasks import sample_task


@pytest.fixture
def hammer_place_world() -> Iterator[tuple[World, PlanRequest]]:
    instance = sample_task("hammer_place", 0)
    with build_world(instance.plan.scene) as world:
        yield world, instance.plan
