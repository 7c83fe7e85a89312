"""``gfc serve`` (the planning service with the default skill library) and ``gfc worker``."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from pathlib import Path
from typing import Annotated

import typer


def register_serve_command(app: typer.Typer) -> None:
    @app.command()
    def serve(
        host: Annotated[str | None, typer.Option(help="interface to bind (env GFC_HOST)")] = None,
        port: Annotated[int | None, typer.Option(help="TCP port (env GFC_PORT)")] = None,
        store: Annotated[
            str | None,
            typer.Option(help="skill store path or URL (env GFC_SKILL_STORE; default: packaged library)"),
        ] = None,
        worker: Annotated[bool, typer.Option(help="also start a verification worker process")] = True,
    ) -> None:
        """Run the planning service (plan, verify jobs, skills, health, metrics; docs at /docs).

        State (the job database, rendered frames) lives under GFC_DATA_DIR (default ./var);
        GFC_DATABASE_URL=postgresql://... puts jobs in PostgreSQL instead. Other settings:
        GFC_MAX_BODY_BYTES, GFC_MAX_CONCURRENT_PLANS, GFC_MAX_QUEUED_PLANS, GFC_TORCH_THREADS.
        Example:

          gfc serve --port 8000 &
          curl -s localhost:8000/health/ready
          curl -s -X POST localhost:8000/plan -H 'content-type: application/json' \\
               -d @gfc/examples/hammer_place.json
        """
        import uvicorn

        from service.admin import SkillAdmin
        from service.fallback import FallbackLibrary
        from service.main import create_app
        from service.settings import Settings
        from service.store_catalog import StoreCatalog
        from skill_store import DEFAULT_LIBRARY, SkillStore, StoreLibrary

        overrides = {
            k: v for k, v in {"host": host, "port": port, "skill_store": store}.items() if v is not None
        }
        settings = Settings(**overrides)  # type: ignore[arg-type]
        settings.data_dir.mkdir(parents=True, exist_ok=True)
        skill_store = SkillStore(settings.skill_store or DEFAULT_LIBRARY)
        library = StoreLibrary(skill_store)
        app = create_app(
            settings,
            FallbackLibrary(library),
            StoreCatalog(skill_store, library),
            admin=SkillAdmin(skill_store, library),
        )
        child = None
        if worker:
            child = subprocess.Popen(
                [sys.executable, "-m", "gfc.cli", "worker", "--database", settings.job_store_url(),
                 "--data-dir", str(settings.data_dir), "--processes", str(settings.verify_processes), "--parent-pid", str(os.getpid())]
            )  # fmt: skip
        typer.echo(
            f"gfc planning service on http://{settings.host}:{settings.port} (skills: {skill_store.location})"
        )
        try:
            uvicorn.run(app, host=settings.host, port=settings.port, log_level="info")
        finally:
            if child is not None:
                child.terminate()
                child.wait(timeout=30)

    @app.command("worker")
    def worker_command(
        database: Annotated[
            str | None, typer.Option(help="job store URL (env GFC_DATABASE_URL; default DATA_DIR/jobs.db)")
        ] = None,
        data_dir: Annotated[
            Path | None, typer.Option(help="where rendered frames go (env GFC_DATA_DIR)")
        ] = None,
        processes: Annotated[int, typer.Option(min=1, help="simulator processes per job")] = 1,
        lease: Annotated[
            float, typer.Option(min=1.0, help="seconds a claimed job stays ours without a heartbeat")
        ] = 30.0,
        parent_pid: Annotated[
            int | None, typer.Option(help="stop when this process is gone (gfc serve's embedded worker)")
        ] = None,
    ) -> None:
        """Run a verification worker: claim jobs, execute candidates in the simulator, report.

        Run as many as you like against one database (PostgreSQL for several machines). A
        worker that dies mid-job stops renewing its lease; after --lease seconds another worker
        takes the job over; after the job's attempt cap it is failed, never run forever.
        """
        import logging

        from service.jobs import open_job_store
        from service.settings import Settings
        from service.worker import verification_worker

        logging.basicConfig(level=logging.INFO, format="%(message)s")
        overrides = {
            k: v for k, v in {"database_url": database, "data_dir": data_dir}.items() if v is not None
        }
        settings = Settings(**overrides)  # type: ignore[arg-type]
        store = open_job_store(settings.job_store_url())
        runner = verification_worker(
            store, settings.data_dir, processes=processes, lease_s=lease, ray_address=settings.ray_address
        )
        typer.echo(f"gfc worker {runner.name} on {settings.job_store_url()}")
        with contextlib.suppress(KeyboardInterrupt):
            runner.run_forever(parent_pid=parent_pid)
