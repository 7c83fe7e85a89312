"""Service settings, read from the environment (``GFC_*``)."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="GFC_", extra="ignore")

    host: str = "127.0.0.1"
    port: int = Field(8000, ge=0, le=65535)
    data_dir: Path = Field(Path("var"), description="job database, renders, logs")
    skill_store: str | None = Field(None, description="path or fsspec URL; default: the packaged library")
    database_url: str | None = Field(
        None, description="job store: sqlite:///PATH or postgresql://...; default: DATA_DIR/jobs.db"
    )
    verify_processes: int = Field(1, ge=1, description="simulator processes per verification job")
    ray_address: str | None = Field(
        None, description="verify on a Ray cluster (auto, ray://host:10001, local) instead of local processes"
    )
    max_verify_candidates: int = Field(20, ge=1, description="candidates one verification job may carry")

    def job_store_url(self) -> str:
        return self.database_url or f"sqlite:///{self.data_dir / 'jobs.db'}"

    max_body_bytes: int = Field(1_000_000, ge=1_000, description="larger requests get 413")
    max_concurrent_plans: int = Field(2, ge=1, description="sampling runs at the same time (each a batch)")
    max_queued_plans: int = Field(
        8, ge=0, description="plans waiting beyond the running batches; more get 503"
    )
    retry_after_s: int = Field(1, ge=1, description="Retry-After sent with 503")
    torch_threads: int = Field(1, ge=1, description="CPU threads per planning call")
    batch_window_ms: float = Field(5.0, ge=0.0, le=1000.0, description="micro-batching window; 0 = off")
    max_batch: int = Field(8, ge=1, le=64, description="plans sampled together at most")
    log_json: bool = True
    management_token: str | None = Field(
        None, min_length=16, description="turns on /admin endpoints (load, unload, alias skill versions)"
    )
