"""Replay or re-screen the logged top-1 plans of a bench trial log at the current code: what an
executor or screen change does to the same plans, with the planner held fixed.

    python scripts/replay_top1.py docs/bench/trials/single_arm_s22_fc5bf3a_hook.jsonl \\
        --task hook_reach_t1 --method gfc
    python scripts/replay_top1.py LOG --task hook_reach_t2 --method gfc --screen
    python scripts/replay_top1.py LOG --task hook_reach_t2 --method gfc --strokes --seeds 4 5 6

Default: execute each trial's logged top-1 actions in a fresh world with the bench's seed and
print the logged outcome beside today's (a replay at the logging commit reproduces the log).
``--screen``: run the kinematic screen (gfc/sim/screen.py) on the same actions instead, and
count the logged successes and failures it now refuses. ``--strokes``: execute up to the first
push or pull and compare where the contact model (gfc/sim/skills/tools.py ``stroke_contact``)
puts the block with where the simulator does, with the angle the hook's face meets it at, and
where both leave it in the frame of an ``aligned`` goal's target on that block (Rearrangement
Push: the rack).
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from gfc.geometry import FloatArray
from gfc.kinds import STROKE_SIGNS, folded_turn, object_kind
from gfc.sim.execute import execute_in_world, execute_plan
from gfc.sim.outcome import SkillFailure
from gfc.sim.screen import Screen
from gfc.sim.skills.tools import stroke_contact, stroke_poses
from gfc.sim.world import build_world, object_matrix
from gfc.tasks import sample_task


def trials(log: Path, task: str, method: str, seeds: list[int] | None) -> Iterator[dict[str, Any]]:
    for line in log.read_text().splitlines():
        row = json.loads(line)
        if (
            row.get("task") == task
            and row.get("method") == method
            and (seeds is None or row["seed"] in seeds)
        ):
            yield row


def actions_of(row: dict[str, Any]) -> list[FloatArray | None]:
    return [None if a is None else np.asarray(a, dtype=np.float64) for a in row["top1_actions"]]


def replay(rows: list[dict[str, Any]], task: str) -> None:
    now_ok = 0
    for row in rows:
        instance = sample_task(task, row["seed"])
        outcome = execute_plan(instance.plan, actions_of(row), seed=row["seed"], contents=instance.contents)
        now_ok += outcome.success
        first = outcome.first_failure
        why = "" if first is None else f"step {first.step}: {first.reason}"
        if first is None and not outcome.success:
            why = "; ".join(outcome.goal_report)
        print(
            f"seed {row['seed']:3d}: logged {row['top1_success']!s:5} now {outcome.success!s:5} {why}",
            flush=True,
        )
    was_ok = sum(bool(r["top1_success"]) for r in rows)
    print(f"top-1 successes: logged {was_ok} of {len(rows)}, now {now_ok} of {len(rows)}")


def rescreen(rows: list[dict[str, Any]], task: str) -> None:
    refused = {True: 0, False: 0}
    for row in rows:
        with Screen(sample_task(task, row["seed"]).plan, row["seed"]) as screen:
            verdict = screen.check(actions_of(row))
        if not verdict.feasible:
            refused[bool(row["top1_success"])] += 1
            logged = (row["top1_failure"] or {}).get("reason", "goal")
            print(
                f"seed {row['seed']:3d} (logged {row['top1_success']}): step {verdict.step}: {verdict.reason} | {logged}"
            )
    ok = sum(bool(r["top1_success"]) for r in rows)
    print(
        f"refused now: {refused[True]} of {ok} logged successes, {refused[False]} of {len(rows) - ok} failures"
    )


def strokes(rows: list[dict[str, Any]], task: str) -> None:
    for row in rows:
        instance = sample_task(task, row["seed"])
        plan, actions = instance.plan, actions_of(row)
        k = next((i for i, s in enumerate(plan.skeleton) if s.skill in STROKE_SIGNS), None)
        if k is None:
            raise SystemExit(f"{task} has no push or pull")
        step, sign = plan.skeleton[k], STROKE_SIGNS[plan.skeleton[k].skill]
        assert step.object is not None and step.target is not None
        action = actions[k]
        assert action is not None
        with build_world(plan.scene, instance.contents) as world:
            before_steps = plan.model_copy(update={"skeleton": plan.skeleton[:k], "goal": []})
            if not execute_in_world(world, before_steps, actions[:k], row["seed"]).success:
                print(f"seed {row['seed']:3d}: a step before the stroke failed")
                continue
            before = object_matrix(world.physics, step.target)
            tool = object_kind(world.physics.objects[step.object].kind)
            poses = stroke_poses(
                world.physics.robots[step.robot].world_from_base,
                before,
                tool,
                world.grasps[step.robot].ee_from_object,
                action,
                sign,
            )
            tool_yaw = math.atan2(poses.world_from_tool[1, 0], poses.world_from_tool[0, 0])
            turn = folded_turn(math.atan2(before[1, 0], before[0, 0]) - tool_yaw)
            half = object_kind(world.physics.objects[step.target].kind).half_extents
            try:
                contact = stroke_contact(tool, poses.world_from_tool, half, before, float(action[2]), sign)
                predicted, note = contact.moved(before, poses.direction), ""
            except SkillFailure as exc:
                predicted, note = before, f"contact model: {exc.reason}"
            stroke_only = plan.model_copy(update={"skeleton": plan.skeleton[k : k + 1], "goal": []})
            outcome = execute_in_world(world, stroke_only, actions[k : k + 1], row["seed"])
            after = object_matrix(world.physics, step.target)
            aligned = next((g for g in plan.goal if g.type == "aligned" and g.object == step.target), None)
            goal_frame = None if aligned is None else object_matrix(world.physics, aligned.target)
        planned = float(np.linalg.norm(predicted[:2, 3] - before[:2, 3]))
        moved = float(np.linalg.norm(after[:2, 3] - before[:2, 3]))
        miss = float(np.linalg.norm(after[:2, 3] - predicted[:2, 3]))
        turned = math.degrees(
            folded_turn(math.atan2(after[1, 0], after[0, 0]) - math.atan2(before[1, 0], before[0, 0]))
        )
        to_goal = ""
        if goal_frame is not None:
            # In the goal target's frame (x, y), as the aligned goal is checked in xy.
            inverse = np.linalg.inv(goal_frame)
            p_goal, a_goal = (inverse @ predicted[:, 3])[:2] * 100, (inverse @ after[:, 3])[:2] * 100
            to_goal = (
                f", to goal (its frame): predicted ({p_goal[0]:+4.1f}, {p_goal[1]:+4.1f}) cm,"
                f" ended ({a_goal[0]:+4.1f}, {a_goal[1]:+4.1f}) cm"
            )
        print(
            f"seed {row['seed']:3d}: turn {math.degrees(turn):+5.1f} deg, predicted {planned * 100:5.1f} cm, "
            f"moved {moved * 100:5.1f} cm, off by {miss * 100:4.1f} cm, block turned {turned:+5.1f} deg, "
            f"stroke {'ok' if outcome.success else 'failed'}{to_goal} {note}",
            flush=True,
        )


def log_parser(doc: str | None) -> argparse.ArgumentParser:
    """A command line that reads one task and method of a trial log (the scripts that study
    logged plans share it)."""
    parser = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("log", type=Path, help="a trial log (gfc bench tasks --log)")
    parser.add_argument("--task", required=True)
    parser.add_argument("--method", default="gfc")
    return parser


def main() -> None:
    parser = log_parser(__doc__)
    parser.add_argument("--seeds", type=int, nargs="*", help="only these trials (default: all logged)")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--screen", action="store_true", help="re-screen instead of executing")
    mode.add_argument("--strokes", action="store_true", help="contact model vs simulator on the first stroke")
    args = parser.parse_args()
    rows = list(trials(args.log, args.task, args.method, args.seeds))
    if not rows:
        raise SystemExit(f"no {args.method} trials of {args.task} in {args.log}")
    if args.screen:
        rescreen(rows, args.task)
    elif args.strokes:
        strokes(rows, args.task)
    else:
        replay(rows, args.task)


if __name__ == "__main__":
    main()
