"""``hands_clear_first``: equivalent hand poses, clear ones first, each group in the given order;
checked lazily, so that a clear commanded pose costs one check."""

from __future__ import annotations

import numpy as np
import pytest

from gfc.geometry import FloatArray
from gfc.sim.collision import CollisionFn
from gfc.sim.outcome import FailureType, SkillFailure
from gfc.sim.skills import motions
from gfc.sim.skills.motions import SkillContext, hands_clear_first
from gfc.sim.world import build_world
from gfc.tasks import sample_task


def _hands(count: int) -> list[FloatArray]:
    """Distinct poses, told apart by their x (the fake IK below reads it)."""
    hands = []
    for k in range(count):
        pose = np.eye(4)
        pose[0, 3] = float(k)
        hands.append(pose)
    return hands


@pytest.mark.parametrize(
    "clear_ones",
    [{0, 1, 2, 3}, {0}, {2}, {1, 3}, set()],
)
def test_clear_hands_come_first_in_order_and_are_checked_only_as_far_as_needed(
    clear_ones: set[int], monkeypatch: pytest.MonkeyPatch
) -> None:
    checked: list[int] = []

    def fake_free_ik(
        ctx: SkillContext, robot: str, world_from_ee: FloatArray, check: CollisionFn, what: str
    ) -> FloatArray:
        k = int(world_from_ee[0, 3])
        checked.append(k)
        if k not in clear_ones:
            raise SkillFailure(FailureType.PATH, "collides")
        return np.zeros(7)

    monkeypatch.setattr(motions, "free_ik", fake_free_ik)
    instance = sample_task("constrained_packing_t1", 0)
    with build_world(instance.plan.scene) as world:
        ctx = SkillContext(world, np.random.default_rng(0))
        hands = _hands(4)
        order = hands_clear_first(ctx, "right", "block_0", hands, 0.04)
        first = next(order)
        # Only as many checked as it took to find the first clear one (all four when none is).
        expected_first = min(clear_ones) if clear_ones else 0
        assert int(first[0, 3]) == expected_first
        assert checked == list(range(expected_first + 1 if clear_ones else 4))
        rest = [int(h[0, 3]) for h in order]
    everything = [int(first[0, 3]), *rest]
    assert everything == sorted(clear_ones) + sorted(set(range(4)) - clear_ones)
    assert checked == [0, 1, 2, 3]  # each checked once, in the given order
