"""The planner's library over the store, and watching the store for changes."""

from __future__ import annotations

import threading

import pytest
import torch

from gfc.diffusion.denoiser import StackedDenoiser
from gfc.examples import load_example
from gfc.plan import compile_plan
from gfc.plan.schema import Options
from gfc.planner.library import random_library, stack_models
from gfc.planner.planner import plan_candidates
from gfc.skills.signatures import SKILLS
from skill_store import SkillStore, StoreChange, StoreLibrary, StoreWatcher
from skill_store.library import IncompatibleModelError, check_action_frame
from skill_store.manifest import Signature, TokenEntry
from tests.skill_store.conftest import SMALL, random_model
from tests.skill_store.test_store import MOVE_LAYOUT


def bank_output(bank: StackedDenoiser) -> torch.Tensor:
    generator = torch.Generator().manual_seed(2)
    m, t, d = len(bank.layouts), bank.mean.shape[1], bank.max_dim
    x = torch.randn(m, 3, t, d, generator=generator)
    return bank.denoise(x, torch.full((m, 3), 0.7), torch.ones(m, 3, t, dtype=torch.bool))


def test_banks_stack_the_resolved_models_in_order(store: SkillStore) -> None:
    pick, move = random_model(0), random_model(1, MOVE_LAYOUT)
    store.publish("pick.hammer", pick)
    store.publish("move.hammer", move)
    store.publish("pick.hammer", random_model(2))
    store.set_alias("pick.hammer@1", "production")
    library = StoreLibrary(store)
    bank = library.bank(["pick.hammer@production", "move.hammer", "pick.hammer@production"])
    assert bank.versions == {"pick.hammer@production": "pick.hammer@1", "move.hammer": "move.hammer@1"}
    expected = stack_models([pick, move, pick])
    assert torch.equal(bank_output(bank.denoiser), bank_output(expected))  # type: ignore[arg-type]
    assert (
        library.bank(["pick.hammer@production", "move.hammer", "pick.hammer@production"]).denoiser
        is bank.denoiser
    )


def test_alias_moves_and_new_versions_reach_the_library_without_a_restart(store: SkillStore) -> None:
    store.publish("pick.hammer", random_model(0))
    library = StoreLibrary(store, state_ttl_s=3600.0)
    assert library.bank(["pick.hammer"]).versions == {"pick.hammer": "pick.hammer@1"}
    store.publish("pick.hammer", random_model(1))
    assert library.bank(["pick.hammer"]).versions == {"pick.hammer": "pick.hammer@1"}  # cached state
    library.refresh()
    assert library.bank(["pick.hammer"]).versions == {"pick.hammer": "pick.hammer@2"}

    store.set_alias("pick.hammer@1", "production")
    instant = StoreLibrary(store, state_ttl_s=0.0)  # re-reads the store on every call
    assert instant.bank(["pick.hammer@production"]).versions["pick.hammer@production"] == "pick.hammer@1"
    store.set_alias("pick.hammer@2", "production")
    assert instant.bank(["pick.hammer@production"]).versions["pick.hammer@production"] == "pick.hammer@2"


def test_the_watcher_reports_new_versions_and_alias_moves(store: SkillStore) -> None:
    store.publish("pick.hammer", random_model(0))
    watcher = StoreWatcher(store)
    assert watcher.poll() == [StoreChange("version_added", "pick.hammer", version=1)]
    assert watcher.poll() == []
    store.publish("pick.hammer", random_model(1), aliases=["production"])
    store.publish("move.hammer", random_model(2, MOVE_LAYOUT))
    assert watcher.poll() == [
        StoreChange("version_added", "move.hammer", version=1),
        StoreChange("version_added", "pick.hammer", version=2),
        StoreChange("alias_moved", "pick.hammer", version=2, alias="production"),
    ]
    store.set_alias("pick.hammer@1", "production")
    store.remove_alias("pick.hammer", "production")
    assert watcher.poll() == [StoreChange("alias_removed", "pick.hammer", alias="production", previous=2)]
    store.set_alias("pick.hammer@1", "production")
    assert watcher.poll() == [StoreChange("alias_moved", "pick.hammer", version=1, alias="production")]


def test_the_background_watcher_calls_back_on_changes(store: SkillStore) -> None:
    seen: list[StoreChange] = []
    changed = threading.Event()

    def on_change(changes: list[StoreChange]) -> None:
        seen.extend(changes)
        changed.set()

    with StoreWatcher(store, on_change, interval_s=0.01):
        store.publish("pick.hammer", random_model(0))
        assert changed.wait(timeout=10)
    assert seen == [StoreChange("version_added", "pick.hammer", version=1)]


def test_the_planner_runs_on_stored_skills_exactly_as_on_in_memory_ones(store: SkillStore) -> None:
    plan = compile_plan(load_example("hammer_nail"))
    in_memory = random_library(plan, SMALL, seed=3)
    for name, model in in_memory.models.items():
        store.publish(name, model, {"seed": 3})
    options = Options(candidates=4, top_k=2, steps=3)
    from_store = plan_candidates(plan, StoreLibrary(store), options)
    expected = plan_candidates(plan, in_memory, options)
    assert from_store.candidates == expected.candidates
    assert set(from_store.models.values()) == {f"{name}@1" for name in in_memory.models}


TOKENS = [TokenEntry(dim=4, type="action")]


def test_a_model_trained_with_another_action_frame_is_refused() -> None:
    push = SKILLS["push"]
    check_action_frame(
        Signature(tokens=TOKENS, skill="push", action_frame=push.action_frame), "push.hook.block@2"
    )
    check_action_frame(Signature(tokens=TOKENS), "my.model@1")  # no skill: nothing to compare
    old = Signature(
        tokens=TOKENS, skill="push", action_frame="STAP/GSC push parameters relative to the target"
    )
    with pytest.raises(IncompatibleModelError, match=r"push.hook.block@1 .* retrain it"):
        check_action_frame(old, "push.hook.block@1")


def test_the_packaged_library_banks_the_models_of_every_task() -> None:
    """Every task's models, stacked as the planner stacks them (in factor order, mixed training
    recipes included), from the library committed under skill_store/library."""
    from gfc.bench.methods import required_models
    from gfc.plan.compiler import compile_plan
    from gfc.tasks import ALL_TASKS, sample_task
    from skill_store import DEFAULT_LIBRARY

    library = StoreLibrary(SkillStore(DEFAULT_LIBRARY))
    for task in ALL_TASKS:
        compiled = compile_plan(sample_task(task, 0).plan)
        refs = [f.model for f in compiled.temporal]
        bank = library.bank(refs)
        assert bank.denoiser.network.n_models == len(refs), task
        assert set(required_models(compiled)) <= {r.split("@")[0] for r in bank.versions.values()}
