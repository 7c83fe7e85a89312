"""Where the fingers are at each placement of logged packing plans, beside whether it slid.

    python scripts/packing_fingers.py docs/bench/trials/single_arm_s19.jsonl \\
        --task constrained_packing_t1 --method gfc

Each trial's logged top-1 actions are walked by the kinematic screen (gfc/sim/screen.py); at
every placement the fingers are closed on the placed block (the opening the screen reads for a
held object) and their depth into every other movable object is measured on the planning mirror.
The table sorts the placements the execution reached by that depth and counts those that failed
with "did not stay where it was released" (a slide) at that step. The screen does not check
this: the fingers are allowed to touch at a placement (the descent may touch).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pybullet as pb
from replay_top1 import actions_of, log_parser, trials  # scripts/, beside this one

from gfc.geometry import FloatArray
from gfc.plan.schema import Step
from gfc.sim.panda import FINGER_JOINTS
from gfc.sim.screen import Screen, _State
from gfc.tasks import sample_task

# (lower, upper] bounds of the fingers' depth into a neighbour, m; depth 0: clear of every one.
BINS = (
    (-1.0, 0.0, "clear"),
    (0.0, 0.003, "0-3 mm in"),
    (0.003, 0.006, "3-6 mm in"),
    (0.006, 1.0, "over 6 mm in"),
)


class FingerScreen(Screen):
    """The screen, noting at each placement how deep the closed fingers reach into the other
    movable objects (step index -> (depth m, object))."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.depths: dict[int, tuple[float, str]] = {}

    def _place(self, state: _State, i: int, step: Step, action: FloatArray) -> None:
        robot, obj = step.robot, step.object
        assert obj is not None
        held = state.held.get(robot)
        super()._place(state, i, step, action)
        if held is None:
            return
        state.held[robot] = held
        self._closed_opening(state, robot, obj)  # leaves the fingers closed on obj
        del state.held[robot]
        mirror = self.world.mirror
        body = mirror.robots[robot].body
        worst, what = 0.0, ""
        for name, other in mirror.objects.items():
            if name == obj or other.fixed:
                continue
            for finger in FINGER_JOINTS:
                for point in pb.getClosestPoints(
                    body, other.body, 0.0, linkIndexA=finger, physicsClientId=mirror.client
                ):
                    if -point[8] > worst:
                        worst, what = -point[8], name
        self.depths[i] = (worst, what)


def placements(log: Path, task: str, method: str) -> list[dict[str, Any]]:
    out = []
    for row in trials(log, task, method, None):
        actions = actions_of(row)
        screen = FingerScreen(sample_task(task, row["seed"]).plan, row["seed"])
        try:
            screen.check(actions)
        finally:
            screen.close()
        failure = row["top1_failure"] or {}
        last = failure.get("step", len(actions))
        for step, (depth, what) in sorted(screen.depths.items()):
            if step > last:
                break
            slid = step == last and "did not stay" in failure.get("reason", "")
            out.append({"seed": row["seed"], "step": step, "depth": depth, "into": what, "slid": slid})
    return out


def main() -> None:
    args = log_parser(__doc__).parse_args()
    rows = placements(args.log, args.task, args.method)
    print(f"{args.task}, {args.method}: {len(rows)} placements reached by the top-1 executions")
    print("| closed fingers at the placement | placements | slid there | rate |")
    print("| --- | --- | --- | --- |")
    for low, high, label in BINS:
        group = [r for r in rows if low < r["depth"] <= high]
        slid = sum(r["slid"] for r in group)
        rate = f"{100 * slid / len(group):.1f} %" if group else "-"
        print(f"| {label} | {len(group)} | {slid} | {rate} |")
    slid_seeds = [f"{r['seed']}:{r['step']}" for r in rows if r["slid"]]
    print("slides (seed:step):", " ".join(slid_seeds) or "none")


if __name__ == "__main__":
    main()
