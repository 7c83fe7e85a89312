"""The task benchmark's plumbing: methods, missing models, failure accounting, the report files.

The CI-sized runs use randomly initialised skill models, so they check shapes and bookkeeping,
not success rates; the ``reference`` oracle checks the success path (its actions solve the
scenes, so its top-1 must be 100%).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from gfc.bench.methods import (
    METHODS,
    SCREEN_KEEP,
    MissingModelsError,
    PlanSettings,
    chain_only,
    check_models,
    decouple,
    make_method,
    required_models,
)
from gfc.bench.report import failure_reasons_markdown, render_key_frames, results_markdown
from gfc.bench.tasks import (
    FAILURE_TYPES,
    BenchResult,
    ExecutionResult,
    StepFailure,
    Trial,
    failure_table,
    run_benchmark,
    summarise,
)
from gfc.cli.app import app
from gfc.plan.compiler import compile_plan
from gfc.planner.library import InMemoryLibrary, random_library
from gfc.pool import InlinePool
from gfc.tasks import sample_task

TASK = "pot_reorientation"
ENTRY_KEYS = {"top1", "any5", "trials", "plan_seconds_median", "failures", "screen_fallbacks", "redrawn"}


def check_failures_add_up(entry: dict[str, object]) -> None:
    failures = entry["failures"]
    assert isinstance(failures, dict)
    per_step = {t: sum(s[t] for s in failures["steps"]) for t in FAILURE_TYPES}
    assert per_step == failures["by_type"]
    counted = sum(failures["by_type"].values()) + failures["goal_not_met"] + failures["succeeded"]
    assert counted == entry["trials"]
    assert failures["succeeded"] / entry["trials"] == entry["top1"]


# ------------------------------------------------------------------ methods


def test_decoupled_plan_shares_no_free_node_and_keeps_the_observed_scene() -> None:
    compiled = compile_plan(sample_task("hammer_nail", 0).plan)
    decoupled = decouple(compiled)
    assert decoupled.spatial == ()
    assert [n.value for n in decoupled.known] == [n.value for n in compiled.known]
    assert all(n.id == i for i, n in enumerate(decoupled.nodes))
    degree = decoupled.temporal_degree()
    assert all(degree[n.id] == 1 for n in decoupled.free)
    assert max(compiled.temporal_degree()[n.id] for n in compiled.free) >= 2  # there was sharing
    # Every factor still reads the observed nodes it read before.
    for old, new in zip(compiled.temporal, decoupled.temporal, strict=True):
        old_known = [compiled.nodes[i].label for i in old.nodes if compiled.nodes[i].known]
        new_known = [decoupled.nodes[i].label for i in new.nodes if decoupled.nodes[i].known]
        assert old_known == new_known
    assert len({n.label for n in decoupled.nodes}) == len(decoupled.nodes)


def test_linear_chain_drops_only_the_spatial_factors() -> None:
    compiled = compile_plan(sample_task("hammer_place", 0).plan)
    assert compiled.spatial, "the task has a goal"
    chain = chain_only(compiled)
    assert chain.temporal == compiled.temporal and chain.nodes == compiled.nodes
    # Implied factors are physics and skill preconditions, not the user's: the chain keeps them
    # (hands and the hammer's release within reach, the hand-over's grasps apart, the cube
    # grasped near the middle of the pads) and drops the goal.
    assert {f.source for f in chain.spatial} == {"implied"}
    assert {f.type for f in chain.spatial} == {"reach", "grasps_apart", "placed_reach", "grasp_centred"}
    assert {f.type for f in compiled.spatial} - {f.type for f in chain.spatial} == {"inside"}
    pour = compile_plan(sample_task("pour_cup", 0).plan)
    kept = chain_only(pour).spatial
    assert sorted({f.type for f in kept}) == ["palm_clear", "reach", "upright"]
    assert {f.type for f in pour.spatial} - {f.type for f in kept} == {"aligned", "near"}


def test_missing_models_are_named() -> None:
    compiled = compile_plan(sample_task("hammer_place", 0).plan)
    library = random_library(compiled)
    del library.models["place.hammer.box"]
    with pytest.raises(MissingModelsError, match=r"place\.hammer\.box") as caught:
        check_models(library, required_models(compiled))
    assert set(caught.value.missing) == {"place.hammer.box"}
    with pytest.raises(MissingModelsError, match=r"move\.pot, pick\.pot"):
        run_benchmark([TASK], ["gfc"], 1, InMemoryLibrary({}), InlinePool())


def test_cli_names_missing_models(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app, ["bench", "tasks", "--tasks", TASK, "--trials", "1", "--skills", str(tmp_path / "empty")]
    )
    assert result.exit_code == 2, result.output
    assert "pick.pot" in result.output and "move.pot" in result.output


@pytest.mark.parametrize("method", METHODS)
def test_methods_return_ranked_candidates_of_the_right_shape(method: str) -> None:
    instance = sample_task(TASK, 1)
    library = random_library(compile_plan(instance.plan))
    planned = make_method(method, library)(instance, PlanSettings(candidates=6, steps=3))
    assert len(planned.candidates) == 6 and planned.seconds >= 0
    # Screened by default: how many passed is counted, up to where screening stops.
    assert planned.passed_screen is not None and 0 <= planned.passed_screen <= SCREEN_KEEP
    for actions in planned.candidates:
        assert [None if a is None else a.shape for a in actions] == [(9,)] * 4


# ------------------------------------------------------------------ accounting


def trial(seed: int, failure: StepFailure | None, goal: bool, passed_screen: int | None = None) -> Trial:
    success = failure is None and goal
    result = ExecutionResult(success, goal, failure, success, 1)
    return Trial(TASK, "gfc", seed, 0.1 * seed, result, (), passed_screen)


def test_screen_fallbacks_count_the_trials_no_candidate_of_which_passed() -> None:
    logged = [
        trial(0, None, True, 0),
        trial(1, None, True, 3),
        trial(2, None, False, 0),
        trial(3, None, True),
    ]
    entry = summarise(BenchResult([TASK], ["gfc"], logged))["tasks"][TASK]["gfc"]
    assert entry["screen_fallbacks"] == 2  # the unlogged trial counts neither way
    unlogged = summarise(BenchResult([TASK], ["gfc"], [trial(0, None, True)]))["tasks"][TASK]["gfc"]
    assert unlogged["screen_fallbacks"] is None


def test_failure_table_counts_each_trial_once() -> None:
    trials = [
        trial(0, StepFailure(0, "pick", 1, "no IK"), False),
        trial(1, StepFailure(0, "pick", 1, "no IK"), False),
        trial(2, StepFailure(2, "move", 2, "no path"), False),
        trial(3, StepFailure(3, "move", 3, "slipped"), False),
        trial(4, None, False),
        trial(5, None, True),
    ]
    table = failure_table(TASK, trials)
    assert [[s[t] for t in FAILURE_TYPES] for s in table["steps"]] == [
        [2, 0, 0],
        [0, 0, 0],
        [0, 1, 0],
        [0, 0, 1],
    ]
    assert table["by_type"] == {"1": 2, "2": 1, "3": 1}
    assert (table["goal_not_met"], table["succeeded"]) == (1, 1)
    summary = summarise(BenchResult([TASK], ["gfc"], trials))
    entry = summary["tasks"][TASK]["gfc"]
    assert entry["top1"] == pytest.approx(1 / 6)
    assert entry["plan_seconds_median"] == pytest.approx(0.25)
    check_failures_add_up(entry)
    text = results_markdown(summary, "gfc bench tasks --trials 6")
    assert f"| {TASK} | gfc | 17% |" in text
    assert "| 0 pick pot (left) | 2/0/0 |" in text


def test_the_commonest_failures_group_reasons_that_differ_only_in_numbers() -> None:
    trials = [
        trial(0, StepFailure(1, "place", 3, "block did not stay: 7.9 cm away"), False),
        trial(1, StepFailure(1, "place", 3, "block did not stay: 4.2 cm away"), False),
        trial(2, StepFailure(0, "pick", 1, "no IK | at (0.61, -0.32)"), False),
        trial(3, None, False),
        trial(4, None, True),
    ]
    lines = failure_reasons_markdown(trials)
    assert f"### {TASK}, gfc" in lines
    rows = [line for line in lines if line.startswith("| ") and "count" not in line and "---" not in line]
    assert rows == [
        "| 2 | 1 place | 3 | block did not stay: # cm away | 0, 1 |",
        "| 1 | - | - | goal | 3 |",
        "| 1 | 0 pick | 1 | no IK / at (#, #) | 2 |",
    ]
    assert failure_reasons_markdown(trials, methods=("random",)) == lines[:3]  # no trials: no tables
    summary = summarise(BenchResult([TASK], ["gfc"], trials))
    assert "## Commonest top-1 failures" in results_markdown(summary, "gfc bench tasks", reasons=lines)


# ------------------------------------------------------------------ end to end


@pytest.mark.slow
def test_reference_oracle_succeeds_and_renders_a_success(tmp_path: Path) -> None:
    result = run_benchmark([TASK], ["reference"], 2, None, InlinePool(), PlanSettings(candidates=5))
    entry = summarise(result)["tasks"][TASK]["reference"]
    assert entry["top1"] == 1.0 and entry["any5"] == 1.0
    check_failures_add_up(entry)
    strips = render_key_frames(result, tmp_path)
    assert [(s.success, s.replayed_success) for s in strips] == [(True, True)]
    assert strips[0].path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_planning_alongside_execution_gives_the_same_trials() -> None:
    """Three trials in chunks of two: pipelined (chunk 2 planned while chunk 1 executes) and in
    turn, the same candidates and the same outcomes, in the same order; the progress adds up."""
    from gfc.pool import LocalPool

    runs = []
    units: list[int] = []
    for pipeline in (True, False):
        units.clear()
        with LocalPool(2, keep_alive=True) as pool:
            result = run_benchmark(
                [TASK],
                ["random"],
                3,
                None,
                pool,
                PlanSettings(candidates=5),
                chunk=2,
                on_progress=lambda _msg, n: units.append(n),
                pipeline=pipeline,
            )
        assert sum(units) == 2 * 3
        runs.append([(t.seed, t.top1_actions, t.result) for t in result.trials])
    assert runs[0] == runs[1]
    assert [seed for seed, _, _ in runs[0]] == [0, 1, 2]


@pytest.mark.slow
def test_ci_sized_run_writes_report_json_plot_and_frames(tmp_path: Path) -> None:
    out, data, plot = tmp_path / "results.md", tmp_path / "results.json", tmp_path / "plot.png"
    args = ["bench", "tasks", "--tasks", TASK, "--trials", "2", "--candidates", "5", "--steps", "4"]
    args += [
        "--random-weights",
        "--processes",
        "2",
        "--out",
        str(out),
        "--json",
        str(data),
        "--plot",
        str(plot),
    ]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    # Not a terminal: the bar does not show, so each phase is logged as a line instead.
    assert f"{TASK}: planning and executing (" in result.output and "units done)" in result.output

    summary = json.loads(data.read_text())
    assert set(summary) == {"tasks"}
    assert set(summary["tasks"]) == {TASK}
    assert set(summary["tasks"][TASK]) == set(METHODS)
    for entry in summary["tasks"][TASK].values():
        assert set(entry) == ENTRY_KEYS
        assert entry["trials"] == 2
        assert 0.0 <= entry["top1"] <= entry["any5"] <= 1.0
        assert entry["plan_seconds_median"] >= 0.0
        assert 0 <= entry["screen_fallbacks"] <= entry["trials"]
        check_failures_add_up(entry)
        assert [s["step"] for s in entry["failures"]["steps"]] == [0, 1, 2, 3]

    text = out.read_text()
    for method in METHODS:
        assert f"| {TASK} | {method} |" in text
    assert "random weights" in text and f"### {TASK}" in text
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # Random weights fail their top-1 executions, so there is a failure strip, linked from the report.
    frame = tmp_path / "results" / f"{TASK}_top1_failure.png"
    assert frame.exists() and "results/" + frame.name in text
