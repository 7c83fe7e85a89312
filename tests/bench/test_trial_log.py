"""The resumable trial log of ``gfc bench tasks --log``: round trips, resuming without redoing
work, refusing a log written under other settings, and surviving a line torn by a crash."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from typer.testing import CliRunner

from gfc.bench.methods import PlanSettings
from gfc.bench.tasks import Execution, ExecutionResult, StepFailure, Trial, run_benchmark, summarise
from gfc.bench.trial_log import TrialLog, TrialLogMismatch, trial_from_json, trial_to_json
from gfc.cli.app import app

TASK = "pot_reorientation"
HEADER: dict[str, Any] = {"settings": {"candidates": 5, "steps": 4}, "models": {"pick.pot": "pick.pot@4"}}


class CountingPool:
    """Stands in for the simulator: every candidate list 'succeeds' when its seed is even."""

    def __init__(self) -> None:
        self.executed: list[tuple[str, int]] = []

    def map(self, fn: Callable[[Any], Any], items: Iterable[Execution]) -> list[ExecutionResult]:
        out = []
        for item in items:
            self.executed.append((item.task, item.seed))
            ok = item.seed % 2 == 0
            failure = None if ok else StepFailure(0, "pick", 3, "slipped")
            out.append(ExecutionResult(ok, ok, failure, ok, 1 if ok else 5))
        return out


def a_trial(seed: int, failure: StepFailure | None = None) -> Trial:
    ok = failure is None
    result = ExecutionResult(ok, ok, failure, ok, 1)
    return Trial(TASK, "random", seed, 0.25, result, ((0.1, 0.2, 0.3), None))


finite = st.floats(min_value=-10, max_value=10, allow_nan=False)


@given(
    actions=st.lists(st.one_of(st.none(), st.lists(finite, min_size=1, max_size=9)), max_size=12),
    failure=st.one_of(
        st.none(), st.builds(StepFailure, st.integers(0, 20), st.text(), st.integers(1, 3), st.text())
    ),
    passed=st.one_of(st.none(), st.integers(0, 5)),
    rounds=st.one_of(st.none(), st.integers(1, 8)),
)
def test_a_trial_survives_json_exactly(
    actions: list[list[float] | None], failure: StepFailure | None, passed: int | None, rounds: int | None
) -> None:
    trial = Trial(
        TASK,
        "gfc",
        7,
        0.5,
        ExecutionResult(False, True, failure, True, 3),
        tuple(None if a is None else tuple(a) for a in actions),
        passed,
        rounds,
    )
    back = trial_from_json(json.loads(json.dumps(trial_to_json(trial))))
    assert back.result == trial.result and (back.task, back.method, back.seed) == (TASK, "gfc", 7)
    assert back.passed_screen == passed and back.rounds == rounds
    assert len(back.top1_actions) == len(trial.top1_actions)
    for got, want in zip(back.top1_actions, trial.top1_actions, strict=True):
        assert (got is None) == (want is None)
        if got is not None and want is not None:
            assert list(got) == list(want)  # bit for bit: a replay executes the very actions


def test_a_resumed_run_executes_only_the_missing_trials(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    first_pool = CountingPool()
    first = run_benchmark(
        [TASK], ["random"], 3, None, first_pool, PlanSettings(candidates=5), log=TrialLog(path, HEADER)
    )
    assert first_pool.executed == [(TASK, 0), (TASK, 1), (TASK, 2)]

    pool = CountingPool()
    log = TrialLog(path, HEADER)
    assert len(log) == 3
    again = run_benchmark([TASK], ["random"], 5, None, pool, PlanSettings(candidates=5), chunk=1, log=log)
    assert pool.executed == [(TASK, 3), (TASK, 4)]  # seeds 0-2 came from the log
    assert [t.seed for t in again.trials] == [0, 1, 2, 3, 4]
    assert [t.result for t in again.trials[:3]] == [t.result for t in first.trials]
    assert summarise(again)["tasks"][TASK]["random"]["top1"] == pytest.approx(3 / 5)
    assert len(path.read_text().splitlines()) == 1 + 5  # the header and one line per trial


def test_a_log_from_other_settings_is_refused_and_left_alone(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    log = TrialLog(path, HEADER)
    log.append(a_trial(0))
    before = path.read_bytes()
    other = {**HEADER, "models": {"pick.pot": "pick.pot@3"}}
    with pytest.raises(
        TrialLogMismatch, match=r"model pick\.pot: log has pick\.pot@4, this run has pick\.pot@3"
    ):
        TrialLog(path, other)
    with pytest.raises(TrialLogMismatch, match=r"settings: log has"):
        TrialLog(path, {**HEADER, "settings": {"candidates": 32, "steps": 4}})
    assert path.read_bytes() == before


def test_a_log_from_before_rounds_existed_reads_as_one_round(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    TrialLog(path, HEADER).append(a_trial(0))  # its header's settings do not say "rounds"
    one = {**HEADER, "settings": {**HEADER["settings"], "rounds": 1}}
    assert len(TrialLog(path, one)) == 1
    with pytest.raises(
        TrialLogMismatch, match=r"settings: log has \{.*'rounds': 1.*\}, this run has \{.*'rounds': 4"
    ):
        TrialLog(path, {**HEADER, "settings": {**HEADER["settings"], "rounds": 4}})


def test_more_models_extend_the_header_and_keep_the_trials(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    TrialLog(path, HEADER).append(a_trial(0))
    wider = {**HEADER, "models": {**HEADER["models"], "move.pot": "move.pot@2"}}
    log = TrialLog(path, wider)
    assert len(log) == 1
    assert json.loads(path.read_text().splitlines()[0])["models"] == wider["models"]
    assert len(TrialLog(path, HEADER)) == 1  # the narrower run still fits


def test_a_torn_last_line_is_dropped_and_appending_continues(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    log = TrialLog(path, HEADER)
    log.append(a_trial(0))
    with path.open("a") as handle:
        handle.write('{"task": "pot_reorientation", "method": "ran')  # the crash
    log = TrialLog(path, HEADER)
    assert [t.seed for t in log] == [0]
    log.append(a_trial(1, StepFailure(0, "pick", 1, "no IK")))
    assert [t.seed for t in TrialLog(path, HEADER)] == [0, 1]


def test_a_damaged_record_in_the_middle_is_an_error_with_its_line(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    log = TrialLog(path, HEADER)
    log.append(a_trial(0))
    log.append(a_trial(1))
    lines = path.read_text().splitlines()
    lines[1] = lines[1][:20]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(TrialLogMismatch, match=r"trials\.jsonl:2: not a trial record"):
        TrialLog(path, HEADER)


def test_recording_a_trial_twice_is_refused(tmp_path: Path) -> None:
    log = TrialLog(tmp_path / "trials.jsonl", HEADER)
    log.append(a_trial(0))
    with pytest.raises(ValueError, match="already recorded"):
        log.append(a_trial(0))


@pytest.mark.slow
def test_the_cli_continues_a_run_from_its_log(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    args = ["bench", "tasks", "--tasks", TASK, "--methods", "random", "--candidates", "5", "--no-frames"]
    args += ["--processes", "1", "--out", str(tmp_path / "r.md"), "--log", str(path)]
    first = CliRunner().invoke(app, [*args, "--trials", "1"])
    assert first.exit_code == 0, first.output
    assert "0 trials recorded" in " ".join(first.output.split())  # (rich wraps long lines)
    second = CliRunner().invoke(app, [*args, "--trials", "2"])
    assert second.exit_code == 0, second.output
    said = " ".join(second.output.split())
    assert "1 trials recorded" in said and "1 trials from the log" in said
    assert len(path.read_text().splitlines()) == 1 + 2
    refused = CliRunner().invoke(app, [*args, "--trials", "2", "--candidates", "6"])
    assert refused.exit_code == 2 and "written by a different run" in " ".join(refused.output.split())


@pytest.mark.slow
def test_the_cli_draws_again_while_nothing_passes_the_screen_and_logs_it(tmp_path: Path) -> None:
    """Uniform random parameters never pass the kinematic screen of the pot task, so a trial with
    ``--rounds 3`` draws three times; the log's header and record say so, and the report counts
    the trial as redrawn."""
    path, report = tmp_path / "trials.jsonl", tmp_path / "r.md"
    args = ["bench", "tasks", "--tasks", TASK, "--methods", "random", "--candidates", "5", "--no-frames"]
    args += ["--processes", "1", "--out", str(report), "--log", str(path), "--trials", "1", "--rounds", "3"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    header, record = (json.loads(line) for line in path.read_text().splitlines())
    assert header["settings"]["rounds"] == 3
    assert (record["passed_screen"], record["rounds"]) == (0, 3)
    assert f"| {TASK} | random | 0% | 0% | 1 | 1 | 1 |" in report.read_text()
    assert "up to 3 draws of 5" in report.read_text()


def test_the_code_fingerprint_follows_outcome_code_only(tmp_path: Path) -> None:
    from gfc.bench.trial_log import code_fingerprint

    (tmp_path / "sim").mkdir()
    (tmp_path / "cli").mkdir()
    (tmp_path / "sim" / "control.py").write_text("SPEED = 1.0\n")
    (tmp_path / "cli" / "app.py").write_text("HELP = 'a'\n")
    before = code_fingerprint(tmp_path)
    (tmp_path / "cli" / "app.py").write_text("HELP = 'b'\n")
    assert code_fingerprint(tmp_path) == before  # the command line does not decide outcomes
    (tmp_path / "sim" / "control.py").write_text("SPEED = 2.0\n")
    assert code_fingerprint(tmp_path) != before


def test_reading_only_accepts_other_code_and_writes_nothing(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    TrialLog(path, {**HEADER, "code": "aaaa"}).append(a_trial(0))
    with path.open("a") as handle:
        handle.write('{"task": "pot')  # a writer busy with its next line
    before = path.read_bytes()
    with pytest.raises(TrialLogMismatch, match="code: log has 'aaaa', this run has 'bbbb'"):
        TrialLog(path, {**HEADER, "code": "bbbb"})
    reader = TrialLog(path, {**HEADER, "code": "bbbb"}, reading_only=True)
    assert [t.seed for t in reader] == [0] and not reader.code_matches
    with pytest.raises(ValueError, match="reading only"):
        reader.append(a_trial(1))
    assert path.read_bytes() == before
    with pytest.raises(TrialLogMismatch, match=r"model pick\.pot"):  # models still must agree
        TrialLog(path, {**HEADER, "code": "bbbb", "models": {"pick.pot": "pick.pot@9"}}, reading_only=True)


def test_report_only_runs_nothing_and_reports_what_the_log_holds(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    pool = CountingPool()
    run_benchmark([TASK], ["random"], 2, None, pool, PlanSettings(candidates=5), log=TrialLog(path, HEADER))
    pool.executed.clear()
    log = TrialLog(path, HEADER, reading_only=True)
    settings = PlanSettings(candidates=5)
    partial = run_benchmark(
        [TASK, "hammer_place"], ["random"], 5, None, pool, settings, log=log, execute=False
    )
    assert pool.executed == []
    summary = summarise(partial)["tasks"]
    assert set(summary) == {TASK}  # hammer_place has no trials yet: no row
    assert summary[TASK]["random"]["trials"] == 2
