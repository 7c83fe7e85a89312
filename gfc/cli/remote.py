"""``gfc plan`` (locally, or on a service with ``--url``) and ``gfc verify --url`` (a service job).

Remote calls go through the Python SDK (``gfc_client``): the same retries, timeouts and errors
a script gets. Exit codes: 0 done, 1 the service failed or no candidate succeeded, 2 invalid
input (the plan, the candidates file, or a request the service refused as invalid).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import typer
from gfc_client import (
    APIConnectionError,
    APIError,
    APIStatusError,
    BadRequestError,
    Candidate,
    Client,
    JobStatus,
    JobWaitTimeout,
    NotFoundError,
)
from rich.console import Console
from rich.table import Table

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_INVALID = 2

console = Console()

URL_HELP = "planning service to use, e.g. http://127.0.0.1:8000 (env GFC_URL); without it, plan locally"


class InputError(Exception):
    """An input file the user must fix."""


def read_json(path: Path, what: str) -> Any:
    if not path.is_file():
        raise InputError(f"{what} {path} does not exist or is not a file")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}:{exc.lineno}:{exc.colno}: not JSON: {exc.msg}") from None


def read_plan(path: Path, overrides: dict[str, int | None]) -> dict[str, Any]:
    """The plan JSON with the command line's sampling options applied on top."""
    plan = read_json(path, "plan")
    if not isinstance(plan, dict):
        raise InputError(f"{path}: a plan is a JSON object with scene, skeleton, constraints, goal")
    chosen = {k: v for k, v in overrides.items() if v is not None}
    if chosen:
        existing = plan.get("options")
        plan["options"] = {**(existing if isinstance(existing, dict) else {}), **chosen}
    return plan


def read_candidates(path: Path) -> list[dict[str, Any]]:
    """``{"candidates": [...]}`` (what ``gfc plan --out`` writes) or a bare list."""
    data = read_json(path, "candidates file")
    items = data.get("candidates") if isinstance(data, dict) else data
    if not isinstance(items, list) or not items or not all(isinstance(c, dict) for c in items):
        raise InputError(f'{path}: expected {{"candidates": [{{"rank": 0, "steps": [...]}}, ...]}}')
    return items


# ---- planning ------------------------------------------------------------------------------


def plan_locally(
    plan: dict[str, Any], store: str | None
) -> tuple[list[Candidate], dict[str, str], dict[str, float]]:
    """Compile and sample in this process with the skill store's library (``gfc serve``'s policy:
    a corrupted version falls back to the newest older one that passes its checks)."""
    from gfc.plan import compile_plan, parse_plan
    from gfc.planner.planner import plan_candidates
    from service.fallback import FallbackLibrary
    from skill_store import DEFAULT_LIBRARY, SkillStore, StoreLibrary

    request = parse_plan(plan)
    compiled = compile_plan(request)
    library = FallbackLibrary(StoreLibrary(SkillStore(store or DEFAULT_LIBRARY)))
    result = plan_candidates(compiled, library, request.options)
    return [Candidate.model_validate(c) for c in result.candidates], result.models, result.timing


def print_candidates(
    candidates: Sequence[Candidate], models: dict[str, str], timing: dict[str, float]
) -> None:
    table = Table(title="candidates (lowest cost first)")
    for column in ("rank", "cost", "constraints met", "steps"):
        table.add_column(column)
    for c in candidates:
        met = sum(r.satisfied for r in c.residuals)
        steps = ", ".join(f"{s.step}:{s.skill}" for s in c.steps)
        table.add_row(str(c.rank), f"{c.cost:.4g}", f"{met}/{len(c.residuals)}", steps)
    console.print(table)
    console.print("models: " + ", ".join(f"{ref} -> {version}" for ref, version in models.items()))
    if "total_s" in timing:
        console.print(f"planned in {timing['total_s']:.2f} s")


def write_candidates(path: Path, candidates: Sequence[Candidate], plan_id: str | None) -> None:
    payload: dict[str, Any] = {"candidates": [c.model_dump(mode="json") for c in candidates]}
    if plan_id:
        payload["plan_id"] = plan_id
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(payload, indent=2))
    console.print(f"wrote {len(candidates)} candidates to {path}")


def report_api_error(exc: APIError) -> int:
    """Print what went wrong and what to do; return the exit code."""
    console.print(f"[bold red]error[/]: {exc.message}", highlight=False)
    if isinstance(exc, APIStatusError) and exc.request_id:
        console.print(f"request id: {exc.request_id} (quote it when asking about this error)")
    if isinstance(exc, APIConnectionError):
        console.print(
            "is the service running there? start one with `gfc serve`, or drop --url to plan locally"
        )
    return EXIT_INVALID if isinstance(exc, BadRequestError | NotFoundError) else EXIT_FAILED


def run_plan(
    plan_file: Path,
    url: str | None,
    store: str | None,
    out: Path | None,
    overrides: dict[str, int | None],
    timeout: float,
) -> int:
    from gfc.plan import PlanError

    try:
        plan = read_plan(plan_file, overrides)
    except InputError as exc:
        console.print(f"[red]error[/]: {exc}", highlight=False)
        return EXIT_INVALID
    plan_id: str | None = None
    if url is None:
        try:
            candidates, models, timing = plan_locally(plan, store)
        except PlanError as exc:
            console.print(f"[bold red]invalid plan[/] {plan_file}: {len(exc.issues)} problem(s)")
            for issue in exc.issues:
                console.print(f"  [red]{issue.loc}[/]: {issue.message}", highlight=False)
            return EXIT_INVALID
        except KeyError as exc:  # a skill the store does not have
            console.print(
                f"[red]error[/]: {exc.args[0]} (list skills with `gfc skills list`)", highlight=False
            )
            return EXIT_INVALID
    else:
        try:
            with Client(url, timeout=timeout) as client:
                response = client.plan(plan)
        except APIError as exc:
            return report_api_error(exc)
        candidates, models, timing, plan_id = (
            response.candidates,
            response.models,
            response.timing,
            response.plan_id,
        )
        console.print(f"plan_id: {plan_id} (verify it with POST /verify or `gfc verify --url`)")
    print_candidates(candidates, models, timing)
    if out is not None:
        write_candidates(out, candidates, plan_id)
    return EXIT_OK


# ---- verification ----------------------------------------------------------------------------


def print_verification(job_id: str, result: dict[str, Any] | None) -> bool:
    """Per candidate and step; returns whether any candidate succeeded."""
    from gfc_client import VerifyResult

    verified = VerifyResult.model_validate(result or {"candidates": [], "any_success": False})
    for outcome in verified.candidates:
        status = "[green]success[/]" if outcome.success else "[red]failed[/]"
        console.print(
            f"candidate rank {outcome.rank}: {status}" + (f" ({outcome.error})" if outcome.error else "")
        )
        for step in outcome.steps:
            mark = "ok" if step.success else f"failure type {step.failure_type}: {step.reason}"
            console.print(f"  step {step.step} {step.skill} ({step.robot}): {mark}", highlight=False)
        for frame in outcome.frames:
            console.print(f"  frames: /jobs/{job_id}/frames/{frame}")
    return verified.any_success


def verify_remote(
    plan_path: Path,
    candidates_path: Path,
    url: str,
    wait: bool,
    *,
    seed: int = 0,
    top_k: int | None = None,
    timeout: float = 600.0,
) -> int:
    """Queue a verification job for PLAN's CANDIDATES on the service at ``url``; with ``wait``,
    poll until it finishes (at most ``timeout`` seconds) and print the outcome.

    Returns 0 when queued (no wait) or when a candidate succeeded, 1 when none did, the job
    failed, timed out or the service could not be reached, 2 when the inputs are invalid.
    """
    try:
        plan = read_plan(plan_path, {})
        candidates = read_candidates(candidates_path)
    except InputError as exc:
        console.print(f"[red]error[/]: {exc}", highlight=False)
        return EXIT_INVALID
    try:
        with Client(url) as client:
            accepted = client.verify(plan=plan, candidates=candidates, seed=seed, top_k=top_k)
            console.print(f"job {accepted.job_id} {accepted.status.value}: {client.base_url}{accepted.url}")
            if not wait:
                return EXIT_OK
            job = client.wait_for_job(accepted.job_id, timeout=timeout)
    except JobWaitTimeout as exc:
        console.print(f"[red]error[/]: {exc}", highlight=False)
        return EXIT_FAILED
    except APIError as exc:
        return report_api_error(exc)
    if job.status is JobStatus.FAILED:
        console.print(
            f"[red]job {job.id} failed after {job.attempts} attempt(s)[/]: {job.error}", highlight=False
        )
        return EXIT_FAILED
    return EXIT_OK if print_verification(job.id, job.result) else EXIT_FAILED


# ---- registration ----------------------------------------------------------------------------


def register_remote_commands(app: typer.Typer) -> None:
    """Adds ``gfc plan``."""

    @app.command("plan")
    def plan_command(
        plan_file: Annotated[
            Path, typer.Argument(help="plan JSON: scene, skeleton, constraints, goal, options")
        ],
        url: Annotated[str | None, typer.Option(help=URL_HELP, envvar="GFC_URL", show_envvar=False)] = None,
        store: Annotated[
            str | None,
            typer.Option(help="local mode: skill store path or URL (env GFC_SKILL_STORE; default: packaged)"),
        ] = None,
        out: Annotated[
            Path | None, typer.Option(help="write the candidates as JSON here (input for `gfc verify`)")
        ] = None,
        candidates: Annotated[int | None, typer.Option(min=1, help="override options.candidates")] = None,
        top_k: Annotated[int | None, typer.Option(min=1, help="override options.top_k")] = None,
        steps: Annotated[
            int | None, typer.Option(min=1, help="override options.steps (sampling steps)")
        ] = None,
        seed: Annotated[int | None, typer.Option(min=0, help="override options.seed")] = None,
        timeout: Annotated[
            float, typer.Option(min=0.1, help="remote mode: seconds to wait for the answer")
        ] = 120.0,
    ) -> None:
        """Sample continuous parameters for every step of a plan and print the candidates, best
        first: cost (lower is better), how many constraint and goal terms they meet, steps.

        Without --url the plan runs in this process with the skill store's models (--store or
        GFC_SKILL_STORE). With --url it is sent to a running `gfc serve`, with retries when the
        service is busy. Exits 0 on success, 2 when the plan is invalid (every problem printed
        with its location) or names a skill model that does not exist, 1 on other failures.

        Examples:

          gfc plan gfc/examples/hammer_place.json --candidates 20 --top-k 3

          gfc plan gfc/examples/hammer_place.json --url http://127.0.0.1:8000 --out run/candidates.json

          gfc verify gfc/examples/hammer_place.json run/candidates.json --url http://127.0.0.1:8000
        """
        import os

        overrides = {"candidates": candidates, "top_k": top_k, "steps": steps, "seed": seed}
        store = store or os.environ.get("GFC_SKILL_STORE")
        raise typer.Exit(run_plan(plan_file, url, store, out, overrides, timeout))
