"""``gfc serve``: the planning service with the default skill library."""

from __future__ import annotations

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
    ) -> None:
        """Run the planning service: POST /plan, GET /skills, health, metrics, docs at /docs.

        Settings come from the environment (GFC_HOST, GFC_PORT, GFC_DATA_DIR, GFC_SKILL_STORE,
        GFC_MAX_BODY_BYTES, GFC_MAX_CONCURRENT_PLANS, GFC_MAX_QUEUED_PLANS, ...); options
        override them. Example:

          gfc serve --port 8000 &
          curl -s localhost:8000/health/ready
          curl -s -X POST localhost:8000/plan -H 'content-type: application/json' \\
               -d @gfc/examples/hammer_place.json
        """
        import uvicorn

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
        app = create_app(settings, library, StoreCatalog(skill_store, library))
        typer.echo(
            f"gfc planning service on http://{settings.host}:{settings.port} (skills: {skill_store.location})"
        )
        uvicorn.run(app, host=settings.host, port=settings.port, log_level="info")
