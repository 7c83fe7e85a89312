"""Collision-free joint-space motion: OMPL RRTConnect, then shortcutting.

The state space stacks the joints of every acting arm (7 for one arm, 14 for two arms moving at
once), so two arms of one group are planned together and cannot hit each other.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from gfc.geometry import FloatArray
from gfc.sim.collision import CollisionFn, first_collision_on_segment
from gfc.sim.panda import ARM_DOF, LOWER_LIMITS, UPPER_LIMITS

ou.setLogLevel(ou.LogLevel.LOG_NONE)

EDGE_RESOLUTION = 0.03  # rad between collision checks along an edge
# RRTConnect's budget: collision checks (about 5 s of one core here), and a wall-clock backstop.
PLANNING_CHECKS = 30_000
PLANNING_TIMEOUT = 30.0  # s
SHORTCUT_ROUNDS = 60


@dataclass(frozen=True)
class MotionResult:
    path: list[FloatArray] | None
    planning_s: float
    reason: str


def _space(dof: int) -> ob.RealVectorStateSpace:
    space = ob.RealVectorStateSpace(dof)
    bounds = ob.RealVectorBounds(dof)
    arms = dof // ARM_DOF
    for i in range(dof):
        bounds.setLow(i, float(np.tile(LOWER_LIMITS, arms)[i]))
        bounds.setHigh(i, float(np.tile(UPPER_LIMITS, arms)[i]))
    space.setBounds(bounds)
    return space


def _rrt_connect(
    check: CollisionFn, start: FloatArray, goal: FloatArray, seed: int, max_checks: int, timeout: float
) -> list[FloatArray] | None:
    # OMPL seeds every sampler from one process-wide generator; re-seeding it before each query
    # makes each query depend only on its own inputs, so a plan replays exactly.
    ou.RNG.setSeed(int(seed) % (2**31 - 1) + 1)
    dof = len(start)
    space = _space(dof)
    info = ob.SpaceInformation(space)
    checks = 0

    def valid(s: Any) -> bool:
        nonlocal checks
        checks += 1
        return check(np.array([s[i] for i in range(dof)])) is None

    info.setStateValidityChecker(valid)
    # OMPL's resolution is a fraction of the space's extent; convert from radians.
    info.setStateValidityCheckingResolution(EDGE_RESOLUTION / space.getMaximumExtent())
    info.setup()
    start_state = space.allocState()
    goal_state = space.allocState()
    for i in range(dof):
        start_state[i] = float(start[i])
        goal_state[i] = float(goal[i])
    problem = ob.ProblemDefinition(info)
    problem.setStartAndGoalStates(start_state, goal_state)
    planner = og.RRTConnect(info)
    planner.setProblemDefinition(problem)
    planner.setup()
    # The budget is counted in collision checks, not seconds, so a query's answer does not depend
    # on how loaded the machine is; the wall-clock limit is only a backstop.
    deadline = time.perf_counter() + timeout
    stop = ob.PlannerTerminationCondition(lambda: checks >= max_checks or time.perf_counter() > deadline)
    solved = planner.solve(stop)
    if not solved or not problem.hasExactSolution():
        return None
    states = problem.getSolutionPath().getStates()
    return [np.array([s[i] for i in range(dof)]) for s in states]


def shortcut(
    check: CollisionFn,
    path: list[FloatArray],
    rng: np.random.Generator,
    rounds: int = SHORTCUT_ROUNDS,
) -> list[FloatArray]:
    """Random shortcutting: join two random points of the path when the segment is free."""
    out = list(path)
    for _ in range(rounds):
        if len(out) < 3:
            break
        i, j = sorted(rng.choice(len(out), size=2, replace=False))
        if j - i < 2:
            continue
        if first_collision_on_segment(check, out[i], out[j], EDGE_RESOLUTION) is None:
            out = out[: i + 1] + out[j:]
    return out


def plan_motion(
    check: CollisionFn,
    start: FloatArray,
    goal: FloatArray,
    rng: np.random.Generator,
    max_checks: int = PLANNING_CHECKS,
    timeout: float = PLANNING_TIMEOUT,
) -> MotionResult:
    """A collision-free joint path from ``start`` to ``goal`` (both included), or why not.

    Given the same inputs and generator state it returns the same path on any machine and under
    any load, unless the wall-clock ``timeout`` cuts the search short first."""
    began = time.perf_counter()
    hit = check(start)
    if hit is not None:
        # The start may graze something it rests on; planning from it would fail at once.
        return MotionResult(
            None, time.perf_counter() - began, f"start in collision: {hit.moving} with {hit.other}"
        )
    hit = check(goal)
    if hit is not None:
        return MotionResult(
            None, time.perf_counter() - began, f"goal in collision: {hit.moving} with {hit.other}"
        )
    if first_collision_on_segment(check, start, goal, EDGE_RESOLUTION) is None:
        return MotionResult([start, goal], time.perf_counter() - began, "direct")
    path = _rrt_connect(check, start, goal, int(rng.integers(2**31 - 2)), max_checks, timeout)
    if path is None:
        spent = time.perf_counter() - began
        return MotionResult(
            None, spent, f"RRTConnect found no path in {max_checks} collision checks ({spent:.1f} s)"
        )
    path = shortcut(check, path, rng)
    return MotionResult(path, time.perf_counter() - began, f"RRTConnect, {len(path)} waypoints")
