"""How often a placement fails against how much room its plan left it: per place step of the
logged top-1 plans, the planned footprint's gap to the blocks placed before it and to the box's
walls (negative: overlapping), and whether that step was the one that failed.

    python scripts/placement_failures.py docs/bench/trials/single_arm_s19.jsonl docs/bench/trials/packing_s24.jsonl

Constrained Packing only (every place is a 5 cm block into the one box; the actions are in the
box's frame, so nothing needs simulating). Steps after a trial's first failure were never
executed and are not counted. Used for the screen's PLACE_OVERLAP (session 25).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from gfc.constraints import footprint_separation
from gfc.geometry import pose9_to_matrix
from gfc.kinds import object_kind

# Upper bin edges (m): a placement goes in the first bin whose edge its gap is below.
EDGES = (-0.001, 0.0, 0.001, 0.002, 0.003, 0.005, 0.008, float("inf"))


def closest_gap(placement: Sequence[float], earlier: Sequence[Sequence[float]]) -> float:
    """The planned footprint's smallest gap to the earlier placements and to the box's walls."""
    block = object_kind("block").half_extents
    inner = object_kind("box").inner_half_extents
    assert inner is not None
    hx, hy, _ = block
    corners = (
        pose9_to_matrix(np.asarray(placement))
        @ np.array([[sx * hx, sy * hy, 0.0, 1.0] for sx in (-1, 1) for sy in (-1, 1)]).T
    )  # (4, 4): box-frame corners as columns
    gaps = [min(inner[0] - np.abs(corners[0]).max(), inner[1] - np.abs(corners[1]).max())]
    pose = torch.tensor([placement], dtype=torch.float64)
    for other in earlier:
        gaps.append(
            float(footprint_separation(pose, torch.tensor([other], dtype=torch.float64), block, block))
        )
    return float(min(gaps))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("logs", nargs="+", type=Path, help="bench trial logs (gfc bench tasks --log)")
    parser.add_argument("--methods", nargs="+", default=["gfc", "linear_chain"])
    args = parser.parse_args()
    counts = {edge: [0, 0] for edge in EDGES}  # edge -> [placements, failed]
    for log in args.logs:
        for line in log.read_text().splitlines():
            row = json.loads(line)
            if "constrained_packing" not in row.get("task", "") or row.get("method") not in args.methods:
                continue
            actions = row["top1_actions"]
            places = [actions[i] for i in range(1, len(actions), 2)]
            failed_step = (row.get("top1_failure") or {}).get("step")
            done = len(places) if failed_step is None else (failed_step + 1) // 2
            for k in range(done):
                gap = closest_gap(places[k], places[:k])
                edge = next(e for e in EDGES if gap < e)
                counts[edge][0] += 1
                counts[edge][1] += failed_step == 2 * k + 1
    print("| planned gap (mm) | placements | failed there | rate |")
    print("|---|---|---|---|")
    low = "-inf"
    for edge, (n, failed) in counts.items():
        high = "inf" if edge == float("inf") else f"{edge * 1000:.0f}"
        rate = f"{100 * failed / n:.1f} %" if n else "-"
        print(f"| {low} to {high} | {n} | {failed} | {rate} |")
        low = high


if __name__ == "__main__":
    main()
