"""``gfc bench standing``: one table of where every task's row stands, read from trial logs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from gfc.bench.standing import (
    STANDING_END,
    STANDING_START,
    read_log,
    replace_block,
    select_standing,
    standing_markdown,
)
from gfc.bench.tasks import ExecutionResult, Trial
from gfc.bench.trial_log import FORMAT, trial_to_json
from gfc.cli.app import app


def write_log(
    path: Path,
    code: str,
    rows: dict[tuple[str, str], tuple[int, int]],
    torn: str = "",
    candidates: int = 32,
    rounds: int | None = None,
) -> Path:
    """A trial log whose (task, method) has ``trials`` trials, the first ``successes`` of which
    succeed; ``rounds`` None: a header from before sampling rounds existed."""
    settings: dict[str, int] = {"candidates": candidates} | ({} if rounds is None else {"rounds": rounds})
    header = {"format": FORMAT, "settings": settings, "code": code, "models": {}}
    lines = [json.dumps(header)]
    for (task, method), (trials, successes) in rows.items():
        for seed in range(trials):
            ok = seed < successes
            result = ExecutionResult(ok, ok, None, ok or seed == trials - 1, 1)
            lines.append(json.dumps(trial_to_json(Trial(task, method, seed, 1.0, result, ()))))
    path.write_text("\n".join(lines) + "\n" + torn, encoding="utf-8")
    return path


def test_read_log_tallies_by_task_and_method_and_ignores_a_torn_last_line(tmp_path: Path) -> None:
    log = write_log(tmp_path / "a.jsonl", "abc", {("hammer_place", "gfc"): (4, 3)}, torn='{"task": "ham')
    contents = read_log(log)
    tally = contents.tallies["hammer_place"]["gfc"]
    assert (tally.trials, tally.top1, tally.any5) == (4, 3, 4)
    assert contents.code == "abc" and contents.candidates == 32


def test_read_log_refuses_a_file_that_is_not_a_trial_log(tmp_path: Path) -> None:
    path = tmp_path / "notes.jsonl"
    path.write_text('{"hello": 1}\n', encoding="utf-8")
    with pytest.raises(ValueError, match="not a trial log"):
        read_log(path)
    with pytest.raises(ValueError, match="cannot read"):
        read_log(tmp_path / "missing.jsonl")


def test_the_log_with_most_gfc_trials_wins_and_a_later_log_wins_a_tie(tmp_path: Path) -> None:
    old = write_log(
        tmp_path / "old.jsonl", "c1", {("hook_reach_t1", "gfc"): (10, 9), ("pour_cup", "gfc"): (10, 1)}
    )
    new = write_log(
        tmp_path / "new.jsonl", "c2", {("hook_reach_t1", "gfc"): (10, 5), ("pour_cup", "gfc"): (4, 4)}
    )
    standings = select_standing([read_log(old), read_log(new)], target_trials=10)
    chosen = {s.task: s.log.path.name for s in standings}
    assert chosen == {"hook_reach_t1": "new.jsonl", "pour_cup": "old.jsonl"}
    # The paper's order: the bimanual rows first.
    assert [s.task for s in standings] == ["pour_cup", "hook_reach_t1"]


def test_a_complete_row_says_whether_it_meets_the_goal_and_beats_every_baseline(tmp_path: Path) -> None:
    rows = {
        ("hook_reach_t1", "gfc"): (10, 9),
        ("hook_reach_t1", "linear_chain"): (10, 9),
        ("hook_reach_t1", "independent"): (10, 2),
        ("hook_reach_t1", "random"): (10, 0),
        ("pour_cup", "gfc"): (10, 9),
        ("pour_cup", "random"): (3, 0),
    }
    log = write_log(tmp_path / "a.jsonl", "same", rows)
    table = standing_markdown(select_standing([read_log(log)], 10), 10, current_code="same")
    hook = next(line for line in table.splitlines() if line.startswith("| hook_reach_t1"))
    cells = [c.strip() for c in hook.strip("|").split("|")]
    assert cells[1].startswith("90 %") and cells[3] == "90 %" and cells[4] == "20 %"
    assert cells[8] == "met"  # 90 % against a goal of 90 %
    assert cells[9] == "**no**"  # a tie with the linear chain is not above it
    assert cells[10] == "32"  # candidates per trial, from the log's header
    assert cells[12] == "yes"
    pour = next(line for line in table.splitlines() if line.startswith("| pour_cup"))
    pour_cells = [c.strip() for c in pour.strip("|").split("|")]
    assert pour_cells[3] == "not run" and pour_cells[5] == "0 % (3 trials)"
    assert pour_cells[9] == "baselines incomplete"
    assert table.startswith(
        "2 tasks with trials; 1 with every method at 10 trials; 2 made by this checkout's code"
    )
    other = standing_markdown(select_standing([read_log(log)], 10), 10, current_code="other")
    assert "no (`same`)" in other and "0 made by this checkout's code" in other


def test_the_candidates_cell_names_the_draws_when_a_trial_may_draw_again(tmp_path: Path) -> None:
    rows = {("hammer_nail", "gfc"): (2, 1)}
    for rounds, cell in ((None, "128"), (1, "128"), (4, "128, up to 4 draws")):
        log = write_log(tmp_path / f"{rounds}.jsonl", "c", rows, candidates=128, rounds=rounds)
        table = standing_markdown(select_standing([read_log(log)], 2), 2, current_code="c")
        line = next(x for x in table.splitlines() if x.startswith("| hammer_nail"))
        assert [c.strip() for c in line.strip("|").split("|")][10] == cell


def test_too_few_gfc_trials_say_so_instead_of_a_verdict(tmp_path: Path) -> None:
    log = write_log(tmp_path / "a.jsonl", "c", {("hammer_nail", "gfc"): (3, 3)})
    table = standing_markdown(select_standing([read_log(log)], 100), 100, current_code="c")
    assert "100 % (44-100), 3 trials" in table and "too few trials" in table
    # The paper's other tasks are listed as not run rather than left out.
    assert "| hammer_nail_v3 | not run |" in table and "| pour_cup | not run |" in table


def test_replace_block_keeps_the_prose_around_it_and_names_missing_markers() -> None:
    text = f"# Results\n\nIntro.\n\n{STANDING_START}\nold table\n{STANDING_END}\n\nNotes.\n"
    out = replace_block(text, "new table\n")
    assert out.startswith("# Results\n\nIntro.\n\n" + STANDING_START)
    assert "new table" in out and "old table" not in out and out.endswith(f"{STANDING_END}\n\nNotes.\n")
    assert replace_block(out, "new table\n") == out  # idempotent
    with pytest.raises(ValueError, match=r"results\.md has no standing block"):
        replace_block("# Results\n", "table", where="results.md")


def test_the_command_writes_the_table_into_the_file(tmp_path: Path) -> None:
    log = write_log(tmp_path / "a.jsonl", "c", {("hammer_place", "gfc"): (2, 1)})
    target = tmp_path / "results.md"
    target.write_text(f"# R\n\n{STANDING_START}\n{STANDING_END}\n", encoding="utf-8")
    runner = CliRunner()
    result = runner.invoke(app, ["bench", "standing", str(log), "--trials", "2", "--into", str(target)])
    assert result.exit_code == 0, result.output
    written = target.read_text(encoding="utf-8")
    assert "| hammer_place | 50 %" in written and "--trials 2 --into" in written
    assert "| hammer_place | 50 %" in result.output
    bad = runner.invoke(app, ["bench", "standing", str(log), "--into", str(tmp_path / "plain.md")])
    assert bad.exit_code == 2 and "cannot read it" in bad.output
