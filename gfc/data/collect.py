"""Collect one skill's transitions in the simulator: random scenes, actions from a broad prior.

A *scenario* samples a scene in which the skill is possible and proposes an action (a heuristic
grasp, say). The collector perturbs the proposal (and draws a share of actions uniformly),
executes the one-step plan in a fresh simulated world, and keeps (pre nodes, action, effect
nodes) of the successes, expressed in the acting robot's base frame as the skill model sees
them. Failures are counted by type. Work fans out over the simulation pool.

Scenarios exist for ``pick`` so far; the other skills (which need a set-up: holding an object,
a second robot holding it, ...) are the next step of the skill-learning issue.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from gfc.geometry import (
    FloatArray,
    matrix_to_pose9,
    pose7_to_matrix,
    pose7_to_pose9,
    pose9_frame_map,
    pose9_to_matrix,
    yaw_quat,
)
from gfc.kinds import HOME_EE_POSE_IN_BASE, OBJECT_KINDS
from gfc.plan.schema import PlanRequest
from gfc.skills.signatures import skill_spec

TABLE_Z = 0.625
BASES = {"left": (0.0, 0.35, TABLE_Z), "right": (0.0, -0.35, TABLE_Z)}
DOWN = np.diag([1.0, -1.0, -1.0])  # gripper pointing down, fingers closing along the object's y


@dataclass(frozen=True)
class Scenario:
    plan: PlanRequest  # one step: the skill to collect
    proposal: FloatArray  # heuristic action for that step


@dataclass(frozen=True)
class Prior:
    """How actions are drawn around a scenario's proposal."""

    position_noise: float = 0.015  # m, per axis
    yaw_noise: float = math.radians(25)
    uniform_share: float = 0.2  # actions drawn uniformly instead
    uniform_extent: float = 0.12  # m, half size of the uniform position box around the object


def _rot_z(angle: float) -> FloatArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _random_rotation(rng: np.random.Generator) -> FloatArray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return pose7_to_matrix([0, 0, 0, *q])[:3, :3]


def pick_scenario(kind: str) -> Callable[[np.random.Generator], Scenario]:
    """An object of ``kind`` on the table in front of a random arm; a top-down grasp at mid
    height across the object's narrower side."""
    half = OBJECT_KINDS[kind].half_extents

    def sample(rng: np.random.Generator) -> Scenario:
        robot = str(rng.choice(["left", "right"]))
        bx, by, _ = BASES[robot]
        x, y = bx + rng.uniform(0.35, 0.55), by + rng.uniform(-0.15, 0.15)
        yaw = rng.uniform(-math.pi, math.pi)
        plan = PlanRequest.model_validate(
            {
                "scene": {
                    "robots": [{"name": n, "base": list(b)} for n, b in BASES.items()],
                    "objects": [{"name": "obj", "kind": kind, "pose": [x, y, TABLE_Z, *yaw_quat(yaw)]}],
                },
                "skeleton": [{"skill": "pick", "robot": robot, "object": "obj"}],
            }
        )
        grasp_yaw = 0.0 if half[1] <= half[0] else math.pi / 2  # close across the narrower side
        grasp = np.eye(4)
        grasp[:3, :3] = _rot_z(grasp_yaw) @ DOWN
        grasp[:3, 3] = [0.0, 0.0, min(half[2], 0.03)]
        return Scenario(plan, matrix_to_pose9(grasp))

    return sample


SCENARIOS: dict[str, Callable[[str], Callable[[np.random.Generator], Scenario]]] = {"pick": pick_scenario}


def draw_action(proposal: FloatArray, prior: Prior, rng: np.random.Generator) -> FloatArray:
    """A 9-D pose action near the proposal, or (``uniform_share``) anywhere plausible."""
    target = np.eye(4)
    if rng.uniform() < prior.uniform_share:
        target[:3, :3] = _random_rotation(rng)
        lift = np.array([0.0, 0.0, prior.uniform_extent])  # above the table, around the object
        target[:3, 3] = rng.uniform(-prior.uniform_extent, prior.uniform_extent, size=3) + lift
    else:
        base = pose9_to_matrix(proposal)
        target[:3, :3] = _rot_z(rng.normal(0, prior.yaw_noise)) @ base[:3, :3]
        target[:3, 3] = base[:3, 3] + rng.normal(0, prior.position_noise, size=3)
    return matrix_to_pose9(target)


def transition_row(plan: PlanRequest, action: FloatArray, after: dict[str, Any]) -> FloatArray:
    """(pre nodes, action, effect nodes) of the plan's single step, flat, in the acting robot's
    base frame (the token order of ``SkillSpec.tokens``)."""
    step = plan.skeleton[0]
    spec = skill_spec(step.skill)
    robot = next(r for r in plan.scene.robots if r.name == step.robot)
    world_from_base = pose7_to_matrix([*robot.base, *yaw_quat(robot.yaw)])
    a, b = pose9_frame_map(world_from_base)
    objects = {o.name: o for o in plan.scene.objects}
    role_entity = {"robot": step.robot, "object": step.object, "target": step.target, "from": step.from_}

    def node_before(entity: str) -> FloatArray:
        if entity in objects:
            return a @ pose7_to_pose9(objects[entity].pose) + b
        # Robots start at home (as the plan compiler assumes for a scene without ee poses).
        r = next(r for r in plan.scene.robots if r.name == entity)
        world = matrix_to_pose9(
            pose7_to_matrix([*r.base, *yaw_quat(r.yaw)]) @ pose7_to_matrix(HOME_EE_POSE_IN_BASE)
        )
        return np.concatenate([a @ world + b, [r.gripper]])

    def node_after(entity: str) -> FloatArray:
        pose = a @ pose7_to_pose9(after["poses"][entity]) + b
        return np.concatenate([pose, [after["grippers"][entity]]]) if entity not in objects else pose

    parts = [node_before(role_entity[r] or "") for r in spec.reads]
    parts.append(np.asarray(action, dtype=np.float64))
    parts += [node_after(role_entity[r] or "") for r in spec.writes]
    return np.concatenate(parts)


@dataclass(frozen=True)
class Attempt:
    skill: str
    kind: str
    seed: int
    prior: Prior


def run_attempt(attempt: Attempt) -> dict[str, Any]:
    """One random scene and action, executed; the transition row on success. (Pool-safe.)"""
    from gfc.sim.execute import execute_plan

    rng = np.random.default_rng(attempt.seed)
    scenario = SCENARIOS[attempt.skill](attempt.kind)(rng)
    action = draw_action(scenario.proposal, attempt.prior, rng)
    outcome = execute_plan(scenario.plan, [action], seed=attempt.seed)
    step = outcome.steps[0]
    if not step.success:
        return {"success": False, "failure_type": step.failure_type}
    row = transition_row(scenario.plan, action, {"poses": step.poses, "grippers": step.grippers})
    return {"success": True, "row": [float(v) for v in row]}


def summarise(results: list[dict[str, Any]]) -> tuple[torch.Tensor, int, dict[str, int]]:
    rows = [r["row"] for r in results if r["success"]]
    failures = Counter(str(r["failure_type"]) for r in results if not r["success"])
    return torch.tensor(rows, dtype=torch.float32), len(results), dict(failures)
