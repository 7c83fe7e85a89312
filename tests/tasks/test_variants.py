"""The benchmark's task variants: they compile, have the promised lengths, keep their base task's
scene, and their reference actions solve sampled scenes in the simulator."""

from __future__ import annotations

import pytest

from gfc.plan.compiler import compile_plan
from gfc.sim.execute import execute_plan
from gfc.tasks import ALL_TASKS, SINGLE_ARM, TASKS, VARIANTS, sample_task

STEPS = {
    "hammer_place_interleaved": 8,
    "hammer_nail_v1": 16,
    "hammer_nail_v2": 18,
    "hammer_nail_v3": 20,
    "pot_reorientation_-45": 4,
    "pot_reorientation_30": 4,
    "pot_reorientation_60": 4,
}
SEEDS = (1, 2)


def test_variants_are_registered_apart_from_the_papers_tasks() -> None:
    assert set(VARIANTS) == set(STEPS)
    assert not set(VARIANTS) & set(TASKS)
    assert set(ALL_TASKS) == set(TASKS) | set(VARIANTS) | set(SINGLE_ARM)
    with pytest.raises(KeyError, match="unknown task"):
        sample_task("hammer_nail_v9", 0)


@pytest.mark.parametrize("task", sorted(STEPS))
def test_variant_compiles_with_its_length(task: str) -> None:
    instance = sample_task(task, 0)
    assert instance.task == task
    assert len(instance.plan.skeleton) == STEPS[task]
    assert len(instance.reference_actions) == STEPS[task]
    compiled = compile_plan(instance.plan)
    assert len(compiled.temporal) + len(compiled.terminal) == STEPS[task]  # strike: no factor


def test_interleaved_skeleton_is_hammer_place_reordered() -> None:
    base, mixed = sample_task("hammer_place", 4), sample_task("hammer_place_interleaved", 4)
    assert mixed.plan.scene == base.plan.scene
    assert mixed.plan.goal == base.plan.goal
    key = [(s.skill, s.robot, s.object) for s in base.plan.skeleton]
    mixed_key = [(s.skill, s.robot, s.object) for s in mixed.plan.skeleton]
    assert sorted(mixed_key) == sorted(key)
    assert mixed_key != key
    # The hammer is handed over before the cube is moved: the sub-tasks really are interleaved.
    assert mixed_key.index(("regrasp", "right", "hammer")) < mixed_key.index(("pick", "left", "cube"))


@pytest.mark.parametrize("task", ["hammer_nail_v1", "hammer_nail_v2", "hammer_nail_v3"])
def test_extended_hammer_nail_keeps_the_base_scene_and_steps(task: str) -> None:
    base, extended = sample_task("hammer_nail", 3), sample_task(task, 3)
    base_objects = {o.name: o for o in base.plan.scene.objects}
    for obj in extended.plan.scene.objects:
        if obj.name in base_objects:
            assert obj == base_objects[obj.name]
    skeleton = [(s.skill, s.robot, s.object) for s in extended.plan.skeleton]
    base_skeleton = [(s.skill, s.robot, s.object) for s in base.plan.skeleton]
    assert [s for s in skeleton if s[2] in base_objects] == base_skeleton
    assert skeleton[-1] == ("strike", "right", "hammer")


@pytest.mark.slow
@pytest.mark.parametrize("task", sorted(STEPS))
def test_variant_reference_actions_succeed(task: str) -> None:
    failures = []
    for seed in SEEDS:
        instance = sample_task(task, seed)
        outcome = execute_plan(
            instance.plan, instance.reference_actions, seed=seed, contents=instance.contents
        )
        if not outcome.success:
            first = outcome.first_failure
            failures.append(
                (seed, first.step if first else None, first.reason if first else outcome.goal_report)
            )
    assert not failures, failures
