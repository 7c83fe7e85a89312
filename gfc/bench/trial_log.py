"""A resumable record of a task benchmark: one JSON line per finished trial.

A 100-trial table over every task and method is hours of simulation on two cores, longer than
one sitting. ``gfc bench tasks --log FILE`` appends each trial as soon as it has been executed;
run the same command again and the trials already in the file are loaded, not redone, so a run
can be stopped (Ctrl-C, a lost machine) and continued, or spread over several sittings.

The first line is the log's header: what produced the trials (planner settings, a fingerprint of
the code that decides outcomes, the resolved version of every skill model). Trials made under
another header
are not comparable, so opening a log with a different header is refused with the differences
named, and nothing in the file is touched. A last line cut short by a crash is dropped (and the
file truncated to its last whole line) so the next append starts on a fresh line.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from gfc.bench.methods import PlanSettings, needs_models, required_models
from gfc.bench.tasks import ExecutionResult, StepFailure, Trial
from gfc.plan.compiler import compile_plan
from gfc.planner.library import SkillLibrary
from gfc.tasks import sample_task

FORMAT = "gfc.bench.trials/1"
TrialKey = tuple[str, str, int]  # (task, method, seed)


class TrialLogMismatch(ValueError):
    """The log was written under other settings or models than this run's."""


def trial_to_json(trial: Trial) -> dict[str, Any]:
    result = trial.result
    failure = result.top1_failure
    return {
        "task": trial.task,
        "method": trial.method,
        "seed": trial.seed,
        "plan_seconds": trial.plan_seconds,
        "top1_success": result.top1_success,
        "top1_goal": result.top1_goal,
        "top1_failure": None
        if failure is None
        else {
            "step": failure.step,
            "skill": failure.skill,
            "failure_type": failure.failure_type,
            "reason": failure.reason,
        },
        "any_success": result.any_success,
        "tried": result.tried,
        # Full precision: a replay must execute the very actions. Rounded to six decimals (a
        # micrometre, a microradian; logs before session 24), a Packing T1 plan whose block the
        # retreat lifted 7.6 cm in the bench was placed cleanly when replayed from the log, and
        # the bench run again on that seed failed as logged.
        "top1_actions": [None if a is None else [float(v) for v in a] for a in trial.top1_actions],
        "passed_screen": trial.passed_screen,
        "rounds": trial.rounds,
    }


def trial_from_json(data: Mapping[str, Any]) -> Trial:
    failure = data["top1_failure"]
    result = ExecutionResult(
        top1_success=bool(data["top1_success"]),
        top1_goal=bool(data["top1_goal"]),
        top1_failure=None
        if failure is None
        else StepFailure(
            int(failure["step"]), str(failure["skill"]), int(failure["failure_type"]), str(failure["reason"])
        ),
        any_success=bool(data["any_success"]),
        tried=int(data["tried"]),
    )
    actions = tuple(None if a is None else tuple(float(v) for v in a) for a in data["top1_actions"])
    return Trial(
        str(data["task"]),
        str(data["method"]),
        int(data["seed"]),
        float(data["plan_seconds"]),
        result,
        actions,
        # Logs before session 22 do not say.
        None if data.get("passed_screen") is None else int(data["passed_screen"]),
        # Logs before session 29 do not say.
        None if data.get("rounds") is None else int(data["rounds"]),
    )


# Code that decides how a trial turns out: everything in gfc except the command line and the
# benchmark's own reporting and bookkeeping. A change there makes old trials incomparable.
_NOT_OUTCOME_CODE = (
    "cli/",
    "bench/report.py",
    "bench/trial_log.py",
    "bench/latency.py",
    "bench/standing.py",
    "bench/parallel.py",
    "data/",
)


def code_fingerprint(root: Path | None = None) -> str:
    """sha256 over the outcome-deciding source files of the gfc package (paths and bytes)."""
    package = root or Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        relative = path.relative_to(package).as_posix()
        if relative.startswith(_NOT_OUTCOME_CODE):
            continue
        digest.update(relative.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def log_header(
    tasks: Sequence[str],
    methods: Sequence[str],
    library: SkillLibrary | None,
    settings: PlanSettings,
    threads: int,
    weights: str,
) -> dict[str, Any]:
    """What decides a trial's outcome besides its task and seed: the planner settings, where the
    weights came from (``store`` or ``random``), the code (``code_fingerprint``) and each skill
    model's resolved version."""
    models: dict[str, str] = {}
    if library is not None and any(needs_models(m) for m in methods):
        for task in tasks:
            for ref in required_models(compile_plan(sample_task(task, 0).plan)):
                models[ref] = library.bank([ref]).versions[ref]
    return {
        "settings": {**asdict(settings), "threads": threads, "weights": weights},
        "code": code_fingerprint(),
        "models": dict(sorted(models.items())),
    }


# Settings added after logs were first written, with the value every earlier log ran at: a header
# without one means that value (rounds: one draw of candidates per trial, before session 29).
LATER_SETTINGS: dict[str, Any] = {"rounds": 1}


def _with_later_settings(header: Mapping[str, Any]) -> dict[str, Any]:
    """``header`` with the settings it predates filled in (``LATER_SETTINGS``)."""
    if "settings" not in header:
        return dict(header)
    return {**header, "settings": {**LATER_SETTINGS, **header["settings"]}}


def _differences(old: Mapping[str, Any], new: Mapping[str, Any], ignore: Sequence[str] = ()) -> list[str]:
    """What makes two headers' trials incomparable. Models are compared where both name them:
    a run over more tasks may bring more models, but a model at another version may not."""
    out = []
    old, new = _with_later_settings(old), _with_later_settings(new)
    for key in sorted((set(old) | set(new)) - {"models", *ignore}):
        if old.get(key) != new.get(key):
            out.append(f"{key}: log has {old.get(key)!r}, this run has {new.get(key)!r}")
    old_models, new_models = old.get("models", {}), new.get("models", {})
    for ref in sorted(set(old_models) & set(new_models)):
        if old_models[ref] != new_models[ref]:
            out.append(f"model {ref}: log has {old_models[ref]}, this run has {new_models[ref]}")
    return out


def _replace(path: Path, data: bytes) -> None:
    """Write ``path`` anew, atomically: readers see the old file or the new one, never half."""
    temporary = path.with_name(path.name + ".tmp")
    with temporary.open("wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(temporary, path)


class TrialLog:
    """Open (or create) the log at ``path`` for a run described by ``header``.

    ``reading_only``: the caller will not add trials (a report of what the log holds), so other
    code than the log's is no reason to refuse; ``code_matches`` then says whether it is the same.
    """

    def __init__(self, path: Path, header: Mapping[str, Any], reading_only: bool = False) -> None:
        self.path = path
        self.reading_only = reading_only
        self.code_matches = True
        self.header = {"format": FORMAT, **header}
        self.trials: dict[TrialKey, Trial] = {}
        if path.exists() and path.stat().st_size > 0:
            self._load()
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._write_line(self.header)

    def _load(self) -> None:
        raw = self.path.read_bytes()
        # A record counts once its newline is written (one write, then fsync); whatever follows
        # the last newline is a line torn by a crash.
        *lines, torn = raw.split(b"\n")
        if not lines:
            raise TrialLogMismatch(f"{self.path}: no header line; not a trial log")
        try:
            header = json.loads(lines[0])
        except json.JSONDecodeError as exc:
            raise TrialLogMismatch(f"{self.path}: the first line is not a trial-log header ({exc})") from None
        if not isinstance(header, dict) or header.get("format") != FORMAT:
            raise TrialLogMismatch(f"{self.path}: not a trial log of this version (expected format {FORMAT})")
        self.code_matches = header.get("code") == self.header.get("code")
        differences = _differences(header, self.header, ignore=("code",) if self.reading_only else ())
        if differences:
            raise TrialLogMismatch(
                f"{self.path} was written by a different run, so its trials cannot be continued: "
                + "; ".join(differences)
                + ". Use another --log file (or delete this one to start over)."
            )
        for number, line in enumerate(lines[1:], start=2):
            if not line.strip():
                continue
            try:
                trial = trial_from_json(json.loads(line))
            except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
                raise TrialLogMismatch(f"{self.path}:{number}: not a trial record ({exc})") from None
            self.trials[(trial.task, trial.method, trial.seed)] = trial
        if self.reading_only:
            self.header = dict(header)
            return
        models = {**header.get("models", {}), **self.header.get("models", {})}
        self.header = {**header, "models": models}
        if models != header.get("models", {}):  # more models than before: the header says so
            lines[0] = json.dumps(self.header, separators=(",", ":")).encode()
            _replace(self.path, b"".join(line + b"\n" for line in lines))  # (drops a torn line)
        elif torn:
            with self.path.open("r+b") as handle:
                handle.truncate(len(raw) - len(torn))

    def _write_line(self, record: Mapping[str, Any]) -> None:
        with self.path.open("a", encoding="utf-8") as handle:
            handle.write(json.dumps(record, separators=(",", ":")) + "\n")
            handle.flush()
            os.fsync(handle.fileno())

    def __contains__(self, key: TrialKey) -> bool:
        return key in self.trials

    def get(self, key: TrialKey) -> Trial | None:
        return self.trials.get(key)

    def __iter__(self) -> Iterator[Trial]:
        return iter(self.trials.values())

    def __len__(self) -> int:
        return len(self.trials)

    def append(self, trial: Trial) -> None:
        if self.reading_only:
            raise ValueError(f"{self.path} was opened for reading only")
        key = (trial.task, trial.method, trial.seed)
        if key in self.trials:
            raise ValueError(f"{self.path}: trial {key} is already recorded")
        self._write_line(trial_to_json(trial))
        self.trials[key] = trial
