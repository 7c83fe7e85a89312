"""Planning latency of the composed sampler: batched versus one network call per factor.

The workload is the paper's longest single plan, Hammer Nail (11 steps, two arms, a handover
and a grouped alignment), with 10 candidates and 50 sampling steps, and DiT-sized skill models
(hidden 128, 2 blocks, 2 heads, MLP ratio 2) randomly initialised: latency does not depend on
the weights. All variants run interleaved in one process, so their ratios are comparable even
on a noisy shared machine.
"""

from __future__ import annotations

import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import torch

from gfc.diffusion.denoiser import Precision
from gfc.examples import load_example
from gfc.plan import compile_plan, parse_plan
from gfc.planner.composed import Compensation
from gfc.planner.library import InMemoryLibrary, random_library
from gfc.planner.planner import plan_candidates, settings_from_options


@dataclass(frozen=True)
class Variant:
    name: str
    description: str
    per_factor: bool = False
    precision: Precision = "float32"
    compensation: Compensation = "marginal"


VARIANTS = (
    Variant("batched", "all factors and marginal queries in one stacked call per step"),
    Variant(
        "per_factor",
        "one call per factor (and one for its marginal queries) per step",
        per_factor=True,
    ),
    Variant("batched_bf16", "batched, network matmuls in bfloat16", precision="bfloat16"),
    Variant(
        "batched_mean_compensation",
        "batched, shared nodes averaged (no marginal queries)",
        compensation="mean",
    ),
    Variant(
        "batched_no_compensation", "batched, shared nodes not compensated (ablation)", compensation="none"
    ),
)


def _cpu_name() -> str:
    try:
        for line in open("/proc/cpuinfo"):  # noqa: SIM115
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def run_latency(
    repeats: int = 5,
    candidates: int = 10,
    steps: int = 50,
    threads: int = 1,
    on_progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Time every variant ``repeats`` times (after one warm-up each), interleaved."""
    torch.set_num_threads(threads)
    request = parse_plan(load_example("hammer_nail"))
    request = request.model_copy(
        update={
            "options": request.options.model_copy(
                update={"candidates": candidates, "top_k": 1, "steps": steps}
            )
        }
    )
    compiled = compile_plan(request)
    fp32 = random_library(compiled)
    libraries = {"float32": fp32, "bfloat16": InMemoryLibrary(fp32.models, precision="bfloat16")}
    times: dict[str, list[float]] = {v.name: [] for v in VARIANTS}

    def once(variant: Variant) -> float:
        settings = replace(settings_from_options(request.options), per_factor=variant.per_factor)
        library = libraries[variant.precision]
        start = time.perf_counter()
        plan_candidates(compiled, library, request.options, settings, compensation=variant.compensation)
        return time.perf_counter() - start

    for variant in VARIANTS:
        once(variant)  # warm-up: allocator, caches, the stacked bank
    for r in range(repeats):
        for variant in VARIANTS:
            times[variant.name].append(once(variant))
            if on_progress is not None:
                on_progress(f"repeat {r + 1}/{repeats}: {variant.name}")

    medians = {name: statistics.median(ts) for name, ts in times.items()}
    return {
        "workload": "hammer_nail",
        "skeleton_steps": len(compiled.temporal) + len(compiled.terminal),
        "candidates": candidates,
        "steps": steps,
        "repeats": repeats,
        "threads": threads,
        "cpu": _cpu_name(),
        "torch": torch.__version__,
        "marginal_queries_per_step": sum(
            1
            for f in compiled.temporal
            for t in f.tokens
            if t.node is not None
            and compiled.temporal_degree().get(t.node, 0) >= 2
            and not compiled.nodes[t.node].known
        ),
        "batched_seconds_median": medians["batched"],
        "per_factor_seconds_median": medians["per_factor"],
        "per_factor_over_batched": medians["per_factor"] / medians["batched"],
        "variants": {
            v.name: {
                "description": v.description,
                "seconds_median": medians[v.name],
                "seconds": times[v.name],
            }
            for v in VARIANTS
        },
    }


def latency_markdown(result: dict[str, Any], command: str) -> str:
    lines = [
        "# Planning latency",
        "",
        f"Workload: {result['workload']} skeleton ({result['skeleton_steps']} steps), "
        f"{result['candidates']} candidates, {result['steps']} sampling steps (Euler), "
        "randomly initialised DiT skill models (hidden 128, 2 blocks, 2 heads, MLP ratio 2), "
        f"{result['marginal_queries_per_step']} marginal queries per step for the compensation term.",
        f"Machine: {result['cpu']}, {result['threads']} torch thread(s), torch {result['torch']}; "
        f"median of {result['repeats']} interleaved repeats.",
        "",
        "| variant | what it does | median seconds | vs batched |",
        "| --- | --- | ---: | ---: |",
    ]
    base = result["batched_seconds_median"]
    for name, v in result["variants"].items():
        lines.append(
            f"| {name} | {v['description']} | {v['seconds_median']:.3f} | {v['seconds_median'] / base:.2f}x |"
        )
    lines += ["", f"Command: `{command}`", ""]
    return "\n".join(lines)
