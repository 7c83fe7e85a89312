"""``gfc skills check``: does a trained skill model propose actions that work, alone, in the simulator?

For fresh scenes of the model's scenario (the same sampler as its data collection), the set-up
runs, the model samples the target stage's action conditioned on the pre nodes the simulator
reports (observed tokens given clean), and the stage executes. The same seeds are then run with
uniformly random actions, so both rates come from the same scenes. Two-handed stages (the pot)
are sampled hand by hand: the second hand's model is also given the object's effect node that
the first hand's sample implies, the chain rule with the models' own conditionals.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import torch

from gfc.data.collect import (
    ActionSource,
    Attempt,
    Source,
    attempts_for,
    pre_nodes,
    robot_frame_map,
    role_entity,
    run_attempt,
)
from gfc.data.scenarios import Scenario, State
from gfc.diffusion.denoiser import StackedDenoiser
from gfc.diffusion.training import sample_model
from gfc.geometry import FloatArray, invert, matrix_to_pose9, pose7_to_pose9, pose9_to_matrix
from gfc.plan.compiler import compile_plan
from gfc.plan.graph import CompiledPlan
from gfc.plan.schema import Options
from gfc.planner.library import InMemoryLibrary
from gfc.planner.planner import plan_candidates
from gfc.pool import Pool
from gfc.skills.signatures import skill_spec

SAMPLING_STEPS = 50
_loaded: dict[tuple[str, str], StackedDenoiser] = {}  # per process: a pool worker loads each model once


def load_model(store: str, ref: str) -> StackedDenoiser:
    key = (store, ref)
    if key not in _loaded:
        from skill_store import SkillStore

        torch.set_num_threads(1)  # one simulator process per core already
        _loaded[key] = SkillStore(store).load(ref).eval()
    return _loaded[key]


def sample_stage(
    model: StackedDenoiser, scenario: Scenario, before: State, rng: np.random.Generator
) -> list[FloatArray]:
    """Actions for the scenario's target steps, each conditioned on its observed pre nodes (and,
    after the first hand, on the shared object's effect that the first sample implies)."""
    plan = scenario.plan
    layout = model.layouts[0]
    generator = torch.Generator().manual_seed(int(rng.integers(2**31)))
    object_effect_world: FloatArray | None = None
    actions: list[FloatArray] = []
    for step in plan.skeleton[scenario.n_setup :]:
        spec = skill_spec(step.skill)
        tokens = spec.tokens(with_object=step.object is not None)
        offsets = np.cumsum([0, *(t.dim for t in tokens)])
        values = torch.zeros(layout.total_dim)
        given = torch.zeros(len(tokens), dtype=torch.bool)
        pre = pre_nodes(plan, step, before)
        values[: len(pre)] = torch.as_tensor(pre, dtype=torch.float32)
        given[[i for i, t in enumerate(tokens) if t.phase == "pre"]] = True
        a, b = robot_frame_map(plan, step.robot)
        effect_object = next(
            (i for i, t in enumerate(tokens) if t.phase == "effect" and t.role == "object"), None
        )
        if object_effect_world is not None and effect_object is not None:
            local = a @ object_effect_world + b
            values[offsets[effect_object] : offsets[effect_object + 1]] = torch.as_tensor(
                local, dtype=torch.float32
            )
            given[effect_object] = True
        sample = sample_model(model, 1, SAMPLING_STEPS, generator=generator, given=(given, values))[0]
        k = next(i for i, t in enumerate(tokens) if t.phase == "action")
        actions.append(sample[offsets[k] : offsets[k + 1]].double().numpy())
        if effect_object is not None and object_effect_world is None:
            local = sample[offsets[effect_object] : offsets[effect_object + 1]].double().numpy()
            object_effect_world = a.T @ (local - b)  # A is orthogonal: back to the world frame
        assert role_entity(step, "robot") == step.robot
    return actions


def stage_graph(scenario: Scenario, before: State) -> CompiledPlan:
    """The factor graph of the scenario's target stage alone: its temporal factors, their pre
    nodes known (the state the set-up left, in the world frame), effects and actions free. For a
    two-handed stage the hands' factors share the object's effect node: composing them is how GFC
    keeps the hands consistent, with the closed-chain factor the compiler adds for a shared grip."""
    compiled = compile_plan(scenario.plan)
    targets = set(range(scenario.n_setup, len(scenario.plan.skeleton)))
    factors = tuple(f for f in compiled.temporal if f.step in targets)
    used = {t.node for f in factors for t in f.tokens if t.node is not None}
    pre = {t.node for f in factors for t in f.tokens if t.phase == "pre" and t.node is not None}
    nodes = []
    for n in compiled.nodes:
        if n.id not in used:
            continue
        if n.id in pre:
            pose = pose7_to_pose9(before["poses"][n.entity])
            value = [*pose, before["grippers"][n.entity]] if n.entity_type == "robot" else list(pose)
            nodes.append(replace(n, known=True, value=tuple(float(v) for v in value)))
        else:
            nodes.append(replace(n, known=False, value=None))
    # The planner indexes nodes and actions by id: renumber both densely.
    node_id = {n.id: i for i, n in enumerate(nodes)}
    kept = [a for a in compiled.actions if a.step in targets]
    action_id = {a.id: i for i, a in enumerate(kept)}
    factors = tuple(
        replace(
            f,
            tokens=tuple(
                replace(
                    t,
                    node=None if t.node is None else node_id[t.node],
                    action=None if t.action is None else action_id[t.action],
                )
                for t in f.tokens
            ),
        )
        for f in factors
    )
    kept_implied = [  # physics the compiler adds (grasps, two hands on one object), never user constraints
        x
        for x in compiled.spatial
        if x.source == "implied" and set(x.nodes) <= used and set(x.actions) <= set(action_id)
    ]
    implied = tuple(
        replace(
            sf,
            index=i,
            nodes=tuple(node_id[n] for n in sf.nodes),
            actions=tuple(action_id[a] for a in sf.actions),
        )
        for i, sf in enumerate(kept_implied)
    )
    return CompiledPlan(
        tuple(replace(n, id=node_id[n.id]) for n in nodes),
        tuple(replace(a, id=action_id[a.id]) for a in kept),
        factors,
        implied,
        (tuple(sorted(targets)),),
    )


def compose_stage(
    model: StackedDenoiser, name: str, scenario: Scenario, before: State, seed: int
) -> list[FloatArray]:
    stage = stage_graph(scenario, before)
    options = Options(candidates=1, top_k=1, steps=SAMPLING_STEPS, seed=seed)
    result = plan_candidates(stage, InMemoryLibrary({name: model}), options)
    return [np.asarray(s["action"], dtype=np.float64) for s in result.candidates[0]["steps"]]


def sample_pre_state(model: StackedDenoiser, seed: int) -> FloatArray:
    """One pre-state row from a pre-state model (a pour's), nothing given: (total_dim,)."""
    generator = torch.Generator().manual_seed(seed)
    return sample_model(model, 1, SAMPLING_STEPS, generator=generator)[0].double().numpy()


def realise_pre_state(scenario: Scenario, row: FloatArray) -> list[FloatArray | None]:
    """The set-up actions of a pour scenario (pick source, pick target, move both) that reach the
    pre-state ``row`` (the pourer's hand, the source, the target, in the pourer's base frame):
    the pourer's grasp is the hand's pose in the source's frame, the moves put each container
    where the row has it; the target's grasp stays the scenario's own (the row does not say it)."""
    plan = scenario.plan
    pourer = plan.skeleton[scenario.n_setup].robot
    a, b = robot_frame_map(plan, pourer)
    hand, source, target = row[:9], row[10:19], row[19:28]
    target_world = a.T @ (target - b)  # A is orthogonal: back to the world frame
    setup = list(scenario.setup_actions)
    for i, step in enumerate(plan.skeleton[: scenario.n_setup]):
        if step.skill == "pick" and step.robot == pourer:
            setup[i] = matrix_to_pose9(invert(pose9_to_matrix(source)) @ pose9_to_matrix(hand))
        elif step.skill == "move" and step.robot == pourer:
            setup[i] = matrix_to_pose9(pose9_to_matrix(source))  # orthonormal rotation columns
        elif step.skill == "move":
            ha, hb = robot_frame_map(plan, step.robot)
            setup[i] = matrix_to_pose9(pose9_to_matrix(ha @ target_world + hb))
    return setup


def model_source(store: str, ref: str) -> ActionSource:
    def draw(scenario: Scenario, before: State, rng: np.random.Generator) -> list[FloatArray]:
        model = load_model(store, ref)
        if scenario.n_target > 1:
            return compose_stage(model, ref.split("@")[0], scenario, before, int(rng.integers(2**31)))
        return sample_stage(model, scenario, before, rng)

    return draw


@dataclass(frozen=True)
class SourceResult:
    trials: int  # attempts whose set-up worked
    successes: int
    failures: dict[str, int]
    setup_failures: int

    @property
    def hit_rate(self) -> float:
        return self.successes / self.trials if self.trials else 0.0


def tally(results: list[dict[str, Any]]) -> SourceResult:
    statuses = Counter(r["status"] for r in results)
    failures = Counter(str(r["failure_type"]) for r in results if r["status"] == "failure")
    tried = len(results) - statuses["setup"]
    return SourceResult(tried, statuses["success"], dict(failures), statuses["setup"])


def run_source(
    model: str, seeds: range, source: Source, pool: Pool, store: str | None = None, ref: str | None = None
) -> SourceResult:
    attempts: list[Attempt] = attempts_for(model, seeds, source, store=store, ref=ref)
    return tally(pool.map(run_attempt, attempts))


def check_report(
    model: str, version: int, trained: SourceResult, random: SourceResult, data_rate: float | None
) -> dict[str, Any]:
    return {
        "model": model,
        "version": version,
        "trials": trained.trials,
        "hit_rate": trained.hit_rate,
        "random_hit_rate": random.hit_rate,
        "random_trials": random.trials,
        "data_success_rate": data_rate,
        "failures": trained.failures,
        "random_failures": random.failures,
        "setup_failures": trained.setup_failures,
    }


CHECK_SEED = 10_000_000  # check scenes are drawn far from the collection's seeds (0, 1, 2, ...)


def check_model(model: str, n: int, store: str, pool: Pool, ref: str | None = None) -> dict[str, Any]:
    """The hit rate of ``ref`` (default: the model's current version) and of uniform random
    actions on the same ``n`` fresh scenes, with the data's own success rate for reference."""
    from skill_store import SkillStore

    skills = SkillStore(store)
    resolved = skills.resolve(ref or model)
    manifest = skills.manifest(resolved)
    pinned = f"{resolved.name}@{resolved.version}"
    seeds = range(CHECK_SEED, CHECK_SEED + n)
    trained = run_source(model, seeds, "model", pool, store=store, ref=pinned)
    random = run_source(model, seeds, "uniform", pool)
    data_rate = manifest.training.metrics.get("data_success_rate")
    return check_report(model, resolved.version, trained, random, data_rate)


def markdown_table(reports: list[dict[str, Any]]) -> str:
    lines = [
        "| skill model | version | trials | hit rate (model) | hit rate (uniform random) | data success rate | model failures by type |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in reports:
        data = "n/a" if r["data_success_rate"] is None else f"{r['data_success_rate']:.0%}"
        failures = ", ".join(f"type {k}: {v}" for k, v in sorted(r["failures"].items())) or "none"
        lines.append(
            f"| {r['model']} | {r['version']} | {r['trials']} | **{r['hit_rate']:.0%}** | "
            f"{r['random_hit_rate']:.0%} | {data} | {failures} |"
        )
    return "\n".join(lines) + "\n"
