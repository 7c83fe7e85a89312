"""Replan one bench trial and watch its placements: pictures and numbers around every release.

    PYTHONPATH=/tmp/worktree python scripts/trace_placements.py constrained_packing_t3 17 --out /tmp/t17

Plans the trial the way the bench does (GFC, 32 candidates, screened, one torch thread; the same
seed gives the same first candidate at the same code, so run it from a worktree of the log's
commit), executes the first candidate, and around each step of every ``place`` (the move above
the target, each straight line: the descent and the retreat, the finger openings, the settling)
prints the placed object's offset from its commanded pose, its tilt and its contacts (partner,
force, normal, depth), and saves close-up frames, eight to a strip, under ``--out``.

``--log`` replays a log's top-1 actions instead of replanning. Execution is chaotic: actions
1e-7 apart end differently (Packing T3 seed 17 failed at step 3 in four of five such runs and at
step 5 in the fifth, session 25), so a rounded log, or a replan with other torch threads, gives
another draw of the same plan, not the bench's run.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as pb

import gfc.sim.skills.placing as placing
from gfc.geometry import FloatArray, invert, pose9_to_matrix
from gfc.sim.execute import EXECUTORS, execute_in_world
from gfc.sim.panda import ee_matrix
from gfc.sim.render import Camera, Rgb, render, save_strip
from gfc.sim.world import World, build_world, object_matrix
from gfc.tasks import sample_task


def contacts(world: World, name: str, skip: str | None = None) -> list[str]:
    """Contacts of ``name`` (an object or a robot) with every other body but ``skip``: its link,
    the partner, normal force and normal."""
    bodies = world.physics
    names = {o.body: n for n, o in bodies.objects.items()}
    names.update({r.body: n for n, r in bodies.robots.items()})
    names[bodies.table] = "table"
    body = bodies.objects[name].body if name in bodies.objects else bodies.robots[name].body
    out = []
    for c in pb.getContactPoints(bodyA=body, physicsClientId=world.client):
        other = names.get(c[2], f"body{c[2]}")
        if c[9] > 0.5 and other != skip:
            n = np.round(np.asarray(c[7]), 2).tolist()
            mine = f"link{c[3]} on " if name in bodies.robots else ""
            out.append(f"{mine}{other}/link{c[4]} {c[9]:.0f} N n={n} d={c[8] * 1000:.1f} mm")
    return out


def describe(world: World, name: str, goal: FloatArray | None) -> str:
    pose = object_matrix(world.physics, name)
    if goal is None:
        return f"{name} at {np.round(pose[:3, 3], 3).tolist()}"
    off = (pose[:3, 3] - goal[:3, 3]) * 100
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(pose[:3, 2] @ goal[:3, 2])))))
    return f"{name} off {np.round(off, 1).tolist()} cm, tilt {tilt:.0f} deg"


class Tracer:
    """Wraps the placing skill's release steps to record frames and numbers."""

    def __init__(self, world: World, target_camera: Camera) -> None:
        self.world = world
        self.camera = target_camera
        self.frames: list[tuple[str, Rgb]] = []
        self.placing: str | None = None
        self.goal: FloatArray | None = None
        self.robot = "right"
        self.lines: list[str] = []

    def snap(self, label: str) -> None:
        obj = self.placing
        if obj is None:
            return
        hand = ee_matrix(self.world.client, self.world.physics.robots[self.robot])
        in_hand = (invert(hand) @ object_matrix(self.world.physics, obj))[:3, 3] * 100
        text = (
            f"{label}: {describe(self.world, obj, self.goal)}, in the hand at {np.round(in_hand, 1).tolist()} cm; "
            + "; ".join(contacts(self.world, obj))
        )
        arm = contacts(self.world, self.robot, skip=obj)
        if arm:
            text += f"; the {self.robot} arm touches: " + "; ".join(arm)
        self.lines.append(text)
        self.frames.append((f"{obj} {label}", render(self.world, self.camera)))

    def wrap(self, name: str, label: str) -> Callable[..., Any]:
        original: Callable[..., Any] = getattr(placing, name)

        def wrapped(*args: Any, **kwargs: Any) -> Any:
            self.snap(f"before {label}")
            result = original(*args, **kwargs)
            self.snap(f"after {label}")
            return result

        setattr(placing, name, wrapped)
        return original


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("task")
    parser.add_argument("seed", type=int)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--log", type=Path, help="replay this log's top-1 actions instead of replanning")
    parser.add_argument("--candidate", type=int, default=0, help="which ranked candidate (replanning)")
    args = parser.parse_args()

    instance = sample_task(args.task, args.seed)
    if args.log:
        rows = [json.loads(x) for x in args.log.read_text().splitlines()[1:]]
        row = next(
            r for r in rows if r.get("task") == args.task and r["seed"] == args.seed and r["method"] == "gfc"
        )
        actions = [None if a is None else np.asarray(a) for a in row["top1_actions"]]
    else:
        import torch

        from gfc.bench.methods import PlanSettings, make_method
        from skill_store import DEFAULT_LIBRARY, SkillStore, StoreLibrary

        torch.set_num_threads(1)  # as the bench plans: other thread counts round differently
        method = make_method("gfc", StoreLibrary(SkillStore(DEFAULT_LIBRARY)))
        planned = method(instance, PlanSettings(candidates=32, screen=True))
        actions = list(planned.candidates[args.candidate])
    print("actions:", json.dumps([None if a is None else np.asarray(a).tolist() for a in actions]))

    with build_world(instance.plan.scene, instance.contents) as world:
        tx, ty = 0.48, -0.12
        camera = Camera(target=(tx, ty, 0.68), distance=0.55, yaw=60.0, pitch=-35.0)
        tracer = Tracer(world, camera)
        originals = {
            "open_gripper": tracer.wrap("open_gripper", "release"),
            "_retreat": tracer.wrap("_retreat", "retreat"),
            "reach": tracer.wrap("reach", "reach above"),
            "straight": tracer.wrap("straight", "straight line"),
        }
        original_place = placing.place

        def place(ctx: Any, step: Any, action: FloatArray) -> str:
            tracer.placing = step.object
            tracer.robot = step.robot
            tracer.goal = object_matrix(world.physics, step.target) @ pose9_to_matrix(action)
            tracer.lines.append(f"--- place {step.object}")
            try:
                return original_place(ctx, step, action)
            finally:
                tracer.snap("settled")
                tracer.placing = None

        placing.place = place
        EXECUTORS["place"] = place
        try:
            outcome = execute_in_world(world, instance.plan, actions, args.seed)
        finally:
            for name, fn in originals.items():
                setattr(placing, name, fn)
            placing.place = original_place
            EXECUTORS["place"] = original_place
    print("\n".join(tracer.lines))
    first = outcome.first_failure
    print("success" if outcome.success else f"failed: {first.reason if first else outcome.goal_report}")
    args.out.mkdir(parents=True, exist_ok=True)
    per = 8
    for k in range(0, len(tracer.frames), per):
        chunk = tracer.frames[k : k + per]
        save_strip(
            [f for _, f in chunk], [c for c, _ in chunk], args.out / f"strip_{k // per:02d}.png", columns=4
        )
    print(f"frames under {args.out}")


if __name__ == "__main__":
    main()
