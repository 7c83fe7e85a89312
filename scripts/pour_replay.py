"""Replay logged Pour Cup plans and follow the beads through the pour: where each one leaves the
mug, how fast, and where it comes to rest, under the executor's pour constants or changed ones.

    python scripts/pour_replay.py docs/bench/trials/bimanual_s18_pour.jsonl --outcome spilled
    python scripts/pour_replay.py LOG --seeds 9 15 19 --set POUR_LIP_LOW=0.005 --set POUR_SPEED=0.3

``--set NAME=VALUE`` overrides a constant of ``gfc.sim.skills.terminal`` (POUR_LIP_LOW,
POUR_SPEED, POUR_ANGLE in degrees, ...) for this process only: a what-if for the pour's motion
with the plans held fixed. The planner is not run; each trial's logged top-1 actions are
executed in a fresh world with the bench's seed, so a replay under the unchanged constants
reproduces the logged outcome. Per trial it prints the pour's outcome and, for every bead that
left the mug, the lip's height over the cup's rim and the bead's speed as it crossed the mug's
lip plane, and where it came to rest along the pouring direction (0 = the cup's centre).
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as pb

import gfc.sim.control as control
import gfc.sim.skills.terminal as terminal
from gfc.kinds import object_kind
from gfc.sim.execute import execute_plan
from gfc.sim.world import World, bead_positions, object_matrix
from gfc.tasks import sample_task


@dataclass
class BeadTrace:
    """What one pour did to the beads (world frame, metres)."""

    direction: np.ndarray | None = None  # (3,) pouring direction
    cup_centre: np.ndarray | None = None  # (3,) cup's rim centre
    left_at: dict[int, tuple[float, float, float]] = field(
        default_factory=dict
    )  # bead -> (lip dz, speed, vz)


def _follow(trace: BeadTrace) -> Callable[[World, int], None]:
    """A replacement for control.step that records the beads after every physics step of a pour."""
    original = vars(control)["step"]

    def step(world: World, count: int = 1) -> None:
        for _ in range(count):
            original(world)
            if trace.direction is not None:
                _record(world, trace)

    return step


def _record(world: World, trace: BeadTrace) -> None:
    mug = object_matrix(world.physics, "mug")
    mug_from_world = np.linalg.inv(mug)
    rim = object_kind(world.physics.objects["mug"].kind).frames["rim"][2]
    for i, body in enumerate(world.physics.beads):
        if i in trace.left_at:
            continue
        position = np.asarray(pb.getBasePositionAndOrientation(body, physicsClientId=world.client)[0])
        local = mug_from_world @ np.array([*position, 1.0])
        if local[2] > rim:  # past the mug's rim plane (mug frame: z up from its bottom)
            velocity = np.asarray(pb.getBaseVelocity(body, physicsClientId=world.client)[0])
            trace.left_at[i] = (
                float(position[2] - trace.cup_centre[2]) if trace.cup_centre is not None else math.nan,
                float(np.linalg.norm(velocity)),
                float(velocity[2]),
            )


def replay(task: str, seed: int, actions: list[Any]) -> tuple[str, BeadTrace, list[float]]:
    instance = sample_task(task, seed)
    trace = BeadTrace()
    original_aim = terminal.aim_pour

    def aim_and_record(*args: Any, **kwargs: Any) -> terminal.PourAim:
        aim = original_aim(*args, **kwargs)
        trace.direction, trace.cup_centre = aim.direction, aim.target_rim
        return aim

    # Patched for this replay only (restored below): the executor looks these up at call time.
    follow = _follow(trace)
    patched = {
        (control, "step"): follow,
        (terminal, "physics_step"): follow,
        (terminal, "aim_pour"): aim_and_record,
    }
    originals = {key: vars(key[0])[key[1]] for key in patched}
    for (module, name), replacement in patched.items():
        vars(module)[name] = replacement
    rests: list[float] = []

    def on_stage(world: World, label: str) -> None:
        if trace.direction is not None and trace.cup_centre is not None:
            rests[:] = [
                float((p - trace.cup_centre)[:2] @ trace.direction[:2]) for p in bead_positions(world)
            ]

    try:
        arrays = [None if a is None or len(a) == 0 else np.asarray(a) for a in actions]
        outcome = execute_plan(
            instance.plan, arrays, seed=seed, contents=instance.contents, on_stage=on_stage
        )
    finally:
        for (module, name), original in originals.items():
            vars(module)[name] = original
    pours = [s for s in outcome.steps if s.skill == "pour"]
    failed = [s for s in outcome.steps if not s.success]
    if pours:
        summary = pours[0].reason
    elif failed:
        summary = f"step {failed[0].step} ({failed[0].skill}) failed: {failed[0].reason}"
    else:
        summary = "no pour"
    return summary, trace, rests


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("log", type=Path, help="a trial log (gfc bench tasks --log)")
    parser.add_argument("--method", default="gfc")
    parser.add_argument("--seeds", type=int, nargs="*", help="only these seeds")
    parser.add_argument(
        "--outcome", choices=("spilled", "succeeded", "all"), default="all", help="which logged trials"
    )
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    args = parser.parse_args()
    for assignment in args.set:
        name, _, value = assignment.partition("=")
        if not hasattr(terminal, name):
            parser.error(f"gfc.sim.skills.terminal has no constant {name!r}")
        number = float(value)
        setattr(terminal, name, math.radians(number) if name == "POUR_ANGLE" else number)
    trials = [json.loads(line) for line in args.log.read_text().splitlines()[1:]]
    chosen = []
    for t in trials:
        if t["task"] != "pour_cup" or t["method"] != args.method or not t.get("top1_actions"):
            continue
        reason = str((t.get("top1_failure") or {}).get("reason", ""))
        logged = "succeeded" if t["top1_success"] else "spilled" if reason.startswith("spilled") else "other"
        if args.seeds is not None and t["seed"] not in args.seeds:
            continue
        if args.outcome != "all" and logged != args.outcome:
            continue
        chosen.append((t, logged))
    landed_total = beads_total = 0
    for t, logged in chosen:
        summary, trace, rests = replay(t["task"], t["seed"], t["top1_actions"])
        print(f"seed {t['seed']:3d} (logged {logged}): {summary}")
        for bead, (dz, speed, vz) in sorted(trace.left_at.items()):
            rest = rests[bead] if bead < len(rests) else math.nan
            print(
                f"    bead {bead}: left at lip {dz * 100:5.1f} cm over the rim, {speed:4.2f} m/s (vz {vz:+.2f}), "
                f"rests {rest * 100:+5.1f} cm along the pour"
            )
        words = summary.split()
        if summary.startswith(("poured", "spilled")):
            landed = int(words[1])
            landed_total += landed
            beads_total += int(words[3])
    if beads_total:
        print(f"landed {landed_total} of {beads_total} beads over {len(chosen)} trials")


if __name__ == "__main__":
    main()
