"""How many of a method's candidates pass the kinematic screen, per scene, and why the rest fail.

    python scripts/screen_pass_rate.py --skills skill_store/library --task pour_cup --seeds 0 8

Used for ADR 0005 (which models let a Pour Cup meeting through the screen). Planning as in
``gfc bench tasks`` (32 candidates, 50 steps), but every candidate is screened, not only until
enough have passed; reasons are counted with their numbers blanked out.
"""

from __future__ import annotations

import argparse
import collections
import re
from dataclasses import replace

from gfc.bench.methods import PlanSettings, make_method
from gfc.sim.screen import screen_order
from gfc.tasks import sample_task
from skill_store import SkillStore, StoreLibrary


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--skills", required=True, help="skill store folder")
    parser.add_argument("--task", required=True)
    parser.add_argument("--seeds", nargs=2, type=int, default=(0, 8), metavar=("FIRST", "END"))
    parser.add_argument("--method", default="gfc")
    parser.add_argument("--candidates", type=int, default=32)
    parser.add_argument("--compensation", choices=("marginal", "mean", "none"), default=None)
    args = parser.parse_args()
    method = make_method(args.method, StoreLibrary(SkillStore(args.skills)))
    settings = PlanSettings(candidates=args.candidates, steps=50, screen=False)
    reasons: collections.Counter[tuple[int | None, str]] = collections.Counter()
    passed = []
    for seed in range(*args.seeds):
        instance = sample_task(args.task, seed)
        if args.compensation is not None:
            options = instance.plan.options.model_copy(update={"compensation": args.compensation})
            instance = replace(instance, plan=instance.plan.model_copy(update={"options": options}))
        candidates = method(instance, settings).candidates
        # keep = all: every candidate gets a verdict (the benchmark stops at SCREEN_KEEP passes).
        _, verdicts = screen_order(instance.plan, candidates, keep=len(candidates) + 1, seed=seed)
        passed.append(sum(v is not None and v.feasible for v in verdicts))
        for v in verdicts:
            if v is not None and not v.feasible:
                reasons[(v.step, re.sub(r"[-0-9.]+", "#", v.reason))] += 1
        print(f"scene {seed}: {passed[-1]} of {len(candidates)} pass", flush=True)
    print(f"passing per scene {passed}, mean {sum(passed) / len(passed):.2f}")
    for (step, reason), count in reasons.most_common(12):
        print(f"{count:4d}  step {step}: {reason}")


if __name__ == "__main__":
    main()
