"""Where the pouring hand was, for every Pour Cup top-1 plan in the trial logs, by outcome.

    python scripts/pour_palm_sides.py docs/bench/trials/*.jsonl

Used for ADR 0013. For each logged Pour Cup trial of one method (default ``gfc``), the hand that
holds the mug at the meeting is the mug's move target composed with the mug's grasp; "towards"
is the cosine between its approach (horizontal part) and the pouring direction (the mug's rim
centre to the cup's). Negative: the palm is between the mug and the cup. A plan logged several
times (the 10-scene checks of sessions 12-16 repeat the same plans) counts once.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
from pathlib import Path

import numpy as np

from gfc.geometry import pose9_to_matrix
from gfc.tasks.base import LEFT_BASE, RIGHT_BASE

# Top-1 actions of the Pour Cup skeleton: pick mug, pick cup, move mug, move cup, pour.
GRASP, MUG_TARGET, CUP_TARGET = 0, 2, 3


def towards(actions: list[list[float] | None]) -> float:
    grasp, mug, cup = (pose9_to_matrix(np.asarray(actions[i])) for i in (GRASP, MUG_TARGET, CUP_TARGET))
    mug[:3, 3] += LEFT_BASE  # the move targets are in their arms' base frames (bases unrotated)
    cup[:3, 3] += RIGHT_BASE
    direction = cup[:2, 3] - mug[:2, 3]
    approach = (mug @ grasp)[:2, 2]
    return float(approach @ direction / (np.linalg.norm(approach) * np.linalg.norm(direction)))


def outcome(trial: dict[str, object]) -> str:
    if trial["top1_success"]:
        return "succeeded"
    failure = trial.get("top1_failure")
    reason = str(failure.get("reason", "")) if isinstance(failure, dict) else ""
    return "spilled" if reason.startswith("spilled") else "failed otherwise"


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("logs", nargs="+", type=Path, help="trial logs (gfc bench tasks --log)")
    parser.add_argument("--method", default="gfc")
    args = parser.parse_args()
    seen: set[str] = set()
    by_outcome: dict[str, list[float]] = collections.defaultdict(list)
    for log in args.logs:
        for line in log.read_text().splitlines():
            trial = json.loads(line)
            if trial.get("task") != "pour_cup" or trial.get("method") != args.method:
                continue
            actions = trial.get("top1_actions")
            if not actions or len(actions) < 4:
                continue
            key = f"{trial['seed']} {towards(actions):.4f}"  # logs round the same plan differently
            if key in seen:
                continue
            seen.add(key)
            by_outcome[outcome(trial)].append(towards(actions))
    print(f"{'top-1 outcome':<18}{'plans':>6}{'palm towards target (cos < 0)':>32}{'cos < -0.02':>13}")
    for name in ("succeeded", "spilled", "failed otherwise"):
        values = np.asarray(by_outcome.get(name, []))
        print(f"{name:<18}{len(values):>6}{int((values < 0).sum()):>32}{int((values < -0.02).sum()):>13}")
    print(f"(cos -0.02 is {math.degrees(math.acos(-0.02)):.1f} degrees from the pouring direction)")


if __name__ == "__main__":
    main()
