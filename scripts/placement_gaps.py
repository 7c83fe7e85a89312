"""How far apart a plan's placements on one target are: per scene, the closest pair of place
actions (footprints, turned as planned) in the top-1 plan, and how many candidates keep 4 mm.

    python scripts/placement_gaps.py --skills skill_store/library --task constrained_packing_t3 --seeds 0 10
    python scripts/placement_gaps.py ... --tolerance 0.005 --clearance 0.006   # session 13's factors

Used for ADR 0010. Planning as in ``gfc bench tasks`` (32 candidates, 50 steps) without the
kinematic screen; nothing is executed. ``--tolerance`` and ``--clearance`` override the
compiler's APART_TOLERANCE and PLACED_CLEARANCE for the run.
"""

from __future__ import annotations

import argparse
import itertools
import statistics

import numpy as np
import torch

import gfc.plan.compiler as compiler
from gfc.bench.methods import PlanSettings, make_method
from gfc.constraints import footprint_separation
from gfc.kinds import OBJECT_KINDS
from gfc.tasks import sample_task
from skill_store import SkillStore, StoreLibrary

KEEP = 0.004  # m: the gap counted as kept


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--skills", required=True, help="skill store folder")
    parser.add_argument("--task", required=True, help="a task whose place steps share one target")
    parser.add_argument("--seeds", nargs=2, type=int, default=(0, 10), metavar=("FIRST", "END"))
    parser.add_argument("--candidates", type=int, default=32)
    parser.add_argument("--method", default="gfc", help="gfc or linear_chain (default gfc)")
    parser.add_argument("--tolerance", type=float, help="m, instead of APART_TOLERANCE")
    parser.add_argument("--clearance", type=float, help="m, instead of PLACED_CLEARANCE")
    args = parser.parse_args()
    if args.tolerance is not None:
        compiler.APART_TOLERANCE = args.tolerance
    if args.clearance is not None:
        compiler.PLACED_CLEARANCE = args.clearance
    method = make_method(args.method, StoreLibrary(SkillStore(args.skills)))
    closest: list[float] = []
    for seed in range(*args.seeds):
        instance = sample_task(args.task, seed)
        plan = method(instance, PlanSettings(candidates=args.candidates, screen=False))
        steps = instance.plan.skeleton
        places = [i for i, s in enumerate(steps) if s.skill == "place" and s.object is not None]
        half = {o.name: OBJECT_KINDS[o.kind].half_extents for o in instance.plan.scene.objects}
        gaps = []
        for actions in plan.candidates:
            pose = {i: torch.tensor(np.asarray([actions[i]], dtype=np.float64)) for i in places}
            gaps.append(
                min(
                    float(
                        footprint_separation(
                            pose[i], pose[j], half[str(steps[i].object)], half[str(steps[j].object)]
                        )
                    )
                    for i, j in itertools.combinations(places, 2)
                )
            )
        closest.append(gaps[0])
        kept = sum(g >= KEEP for g in gaps)
        rank = sorted(gaps, reverse=True).index(gaps[0]) + 1
        print(
            f"seed {seed}: top-1 closest pair {gaps[0] * 1000:.1f} mm "
            f"(candidates' median {statistics.median(gaps) * 1000:.1f} mm, top-1 is {rank} by room); "
            f"{kept}/{len(gaps)} candidates keep 4 mm"
        )
    print(
        f"median top-1 closest pair {statistics.median(closest) * 1000:.1f} mm; "
        f"{sum(g >= KEEP for g in closest)}/{len(closest)} top-1 plans keep 4 mm "
        f"({args.method}; APART_TOLERANCE {compiler.APART_TOLERANCE}, PLACED_CLEARANCE {compiler.PLACED_CLEARANCE})"
    )


if __name__ == "__main__":
    main()
