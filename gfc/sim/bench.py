"""Timing of the simulator: physics steps per second, skill and plan wall times, motion planning.

``gfc sim bench`` runs the tasks' reference parameters on sampled scenes and writes a Markdown
table (docs/bench/sim.md is produced this way).
"""

from __future__ import annotations

import platform
import statistics
import time
from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from gfc.plan.schema import Scene
from gfc.sim.bodies import TABLE_TOP_Z
from gfc.sim.collision import make_collision_fn
from gfc.sim.execute import execute_plan
from gfc.sim.ik import solve_ik
from gfc.sim.motion import plan_motion
from gfc.sim.panda import HOME_JOINTS
from gfc.sim.world import build_world, step
from gfc.tasks import TASKS, sample_task
from gfc.tasks.base import frame


@dataclass
class SimBenchmark:
    scenes: int
    steps_per_second: float = 0.0
    build_s: float = 0.0
    plan_wall: dict[str, list[float]] = field(default_factory=lambda: defaultdict(list))
    plan_success: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    skill_wall: dict[str, list[float]] = field(default_factory=lambda: defaultdict(list))
    skill_planning: dict[str, list[float]] = field(default_factory=lambda: defaultdict(list))
    rrt_s: list[float] = field(default_factory=list)


def _physics_rate(steps: int = 2400) -> tuple[float, float]:
    instance = sample_task("hammer_place", 0)
    began = time.perf_counter()
    with build_world(instance.plan.scene) as world:
        built = time.perf_counter() - began
        began = time.perf_counter()
        step(world, steps)
        return steps / (time.perf_counter() - began), built


def _rrt_times(repeats: int) -> list[float]:
    """RRTConnect around a rack that blocks the straight path (as in tests/sim/test_motion.py)."""
    scene = Scene.model_validate(
        {
            "robots": [
                {"name": "left", "base": [0.0, 0.35, TABLE_TOP_Z]},
                {"name": "right", "base": [0.0, -0.35, TABLE_TOP_Z]},
            ],
            "objects": [
                {"name": "rack", "kind": "rack", "pose": [0.45, 0.35, TABLE_TOP_Z, 0, 0, 0, 1], "fixed": True}
            ],
        }
    )
    down = np.diag([1.0, -1.0, -1.0])
    out = []
    with build_world(scene) as world:
        check = make_collision_fn(world, ["left"])
        rng = np.random.default_rng(0)
        home = np.asarray(HOME_JOINTS)
        a = solve_ik(world, "left", frame([0.45, 0.76, TABLE_TOP_Z + 0.05], down), home, rng)
        b = solve_ik(world, "left", frame([0.45, -0.06, TABLE_TOP_Z + 0.05], down), home, rng)
        assert a is not None and b is not None
        for k in range(repeats):
            result = plan_motion(check, a, b, np.random.default_rng(k))
            out.append(result.planning_s)
    return out


def run_benchmark(scenes: int) -> SimBenchmark:
    bench = SimBenchmark(scenes)
    bench.steps_per_second, bench.build_s = _physics_rate()
    for task in sorted(TASKS):
        for seed in tqdm(range(scenes), desc=task):
            instance = sample_task(task, seed)
            outcome = execute_plan(
                instance.plan, instance.reference_actions, seed=seed, contents=instance.contents
            )
            bench.plan_wall[task].append(outcome.wall_s)
            bench.plan_success[task] += int(outcome.success)
            for s in outcome.steps:
                if s.success:
                    bench.skill_wall[s.skill].append(s.timings.wall_s)
                    bench.skill_planning[s.skill].append(s.timings.planning_s)
    bench.rrt_s = _rrt_times(10)
    return bench


def _ms(values: list[float]) -> str:
    if not values:
        return "-"
    return f"{statistics.median(values) * 1000:.0f} / {np.percentile(values, 90) * 1000:.0f}"


def to_markdown(bench: SimBenchmark, command: str) -> str:
    lines = [
        "# Simulator benchmark",
        "",
        f"Produced by `{command}` on {platform.machine()} ({platform.processor() or 'cpu'}), "
        f"Python {platform.python_version()}, one process. Times are wall clock; "
        '"median / p90" in milliseconds. The rest of a skill\'s time is physics (robots move at '
        "1 rad/s, approaches at 0.5, pours at 0.5 with a 1 s hold), IK and scene queries.",
        "",
        f"- physics: **{bench.steps_per_second:,.0f} steps/s** (240 Hz steps of the Hammer Place scene: "
        f"two Pandas, 6 objects; {bench.steps_per_second / 240:.0f}x real time)",
        f"- building a scene (physics client + planning mirror, settled): {bench.build_s * 1000:.0f} ms",
        f"- RRTConnect + shortcutting around an obstacle (7 DoF, 10 seeds): {_ms(bench.rrt_s)}",
        "",
        "## Full plans (reference parameters)",
        "",
        "| task | scenes | success | wall per plan (median / p90, ms) |",
        "| --- | --- | --- | --- |",
    ]
    for task in sorted(bench.plan_wall):
        lines.append(
            f"| {task} | {bench.scenes} | {bench.plan_success[task]}/{bench.scenes} | {_ms(bench.plan_wall[task])} |"
        )
    lines += [
        "",
        "## Per skill execution (successful steps; a group's time is split between its steps)",
        "",
        "| skill | executions | wall (median / p90, ms) | of which OMPL motion planning (median / p90, ms) |",
        "| --- | --- | --- | --- |",
    ]
    for skill in sorted(bench.skill_wall):
        lines.append(
            f"| {skill} | {len(bench.skill_wall[skill])} | {_ms(bench.skill_wall[skill])} | {_ms(bench.skill_planning[skill])} |"
        )
    return "\n".join(lines) + "\n"
