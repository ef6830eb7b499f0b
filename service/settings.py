"""Service settings, from FLOORPLAN_* environment variables or a .env file."""

from __future__ import annotations

import ipaddress
import os
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

#: The names a service bound to loopback answers to by default.
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "[::1]")


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


class Settings(BaseSettings):
    """Every knob of `floorplan serve` and `floorplan worker`; each is documented in the
    README."""

    model_config = SettingsConfigDict(env_prefix="FLOORPLAN_", env_file=".env", extra="ignore")

    backend: Literal["embedded", "celery"] = Field(
        "embedded", description="embedded: solves run in this process's children; celery: "
        "API nodes queue jobs for `floorplan worker` nodes through Redis",
    )
    database_url: str | None = Field(
        None, description="SQLAlchemy URL of the job store (e.g. postgresql+psycopg://...); "
        "default: SQLite in data_dir",
    )
    redis_url: str = Field(
        "redis://127.0.0.1:6379/0", description="the broker and pub/sub (celery backend)"
    )
    namespace: str = Field(
        "floorplan", pattern=r"^[A-Za-z0-9_.-]{1,64}$",
        description="the Celery queue and the prefix of every Redis key and channel",
    )
    lease_seconds: float = Field(
        30.0, gt=0, description="a running job whose worker has not renewed its lease for "
        "this long is run again elsewhere (celery backend)",
    )
    reconcile_seconds: float = Field(
        10.0, gt=0, description="how often API nodes and workers look for lost jobs",
    )

    host: str = Field("127.0.0.1", description="address to listen on")
    port: int = Field(8000, ge=0, le=65535, description="port to listen on (0: any free one)")
    workers: int = Field(
        default_factory=lambda: os.cpu_count() or 1, ge=1,
        description="solves running at once, each in its own process",
    )
    data_dir: Path = Field(Path("data"), description="where the SQLite job store lives")
    min_free_bytes: int = Field(
        64 << 20, ge=0, description="free space the SQLite job store's disk must keep: "
        "under it /readyz is 503 and new jobs are refused with 503 (0: no check)",
    )
    max_body_bytes: int = Field(1 << 20, ge=1024, description="largest accepted request body")
    max_rooms: int = Field(400, ge=1, description="most rooms in one problem")
    max_vertices: int = Field(
        500, ge=4, le=1000, description="most vertices of an outline (the boundary, each "
        "floor's); beyond, 413 before the problem is validated",
    )
    max_obstacles: int = Field(
        200, ge=0, le=1000, description="most obstacles (top-level, each floor's); beyond, "
        "413 before the problem is validated",
    )
    max_extent: float = Field(
        10_000.0, gt=0, description="widest or deepest outline (the boundary, each "
        "floor's) in metres; beyond, 422 naming the outline",
    )
    max_regions: int = Field(
        200, ge=0, description="most regions in one problem; beyond, 413 before the problem "
        "is validated",
    )
    parse_threads: int = Field(
        2, ge=1, description="request bodies parsed and validated at once, each in a worker "
        "thread off the event loop; more wait their turn",
    )
    max_time_limit: float = Field(600.0, gt=0, description="largest options.time_limit allowed")
    queue_limit: int = Field(1000, ge=1, description="jobs waiting at most; beyond, 429")
    max_jobs_per_key: int = Field(
        400, ge=1, description="queued and running jobs of one API key (of everyone when "
        "keys are off) at most; beyond, 429 too-many-jobs. Keep it under queue_limit so "
        "that one key cannot fill the queue for the others",
    )
    max_batch_bytes: int = Field(
        64 << 20, ge=1024, description="most bytes the brief of one batch takes in the job "
        "store (stored once, whatever the count: each layout's problem is derived from "
        "it); beyond, 413 batch-too-large",
    )
    max_stored_bytes_per_key: int = Field(
        1 << 30, ge=1024, description="bytes one API key's jobs may keep in the store "
        "(problems, results, incumbents; finished and canceled jobs until deleted); a job or "
        "batch that would pass it is refused with 429 storage-quota",
    )
    max_streams_per_key: int = Field(
        20, ge=1, description="open event streams of one API key per API process; beyond, "
        "429 too-many-streams",
    )
    max_streams: int = Field(
        500, ge=1, description="open event streams per API process, every key's; beyond, "
        "429 too-many-streams",
    )
    max_explains_per_key: int = Field(
        2, ge=1, description="POST /v1/validate?explain=true calls of one API key at once "
        "per API process; beyond, 429 too-many-explains",
    )
    explain_processes: int = Field(
        2, ge=1, description="explaining validations (SCIP) running at once, each in a "
        "process of the API node's own pool; more wait their turn",
    )
    export_processes: int = Field(
        2, ge=1, description="exports (IFC, DXF, SVG, GeoJSON) made at once, each in a "
        "process of the API node's own pool; more wait their turn",
    )
    grace_seconds: float = Field(
        5.0, ge=0, description="after time_limit + grace a solve is interrupted, after another "
        "grace it is killed",
    )
    retry_limit: int = Field(
        2, ge=0, description="restarts of a job whose service stopped under it, then it fails"
    )
    retention_hours: float = Field(
        168.0, gt=0, description="finished jobs older than this are deleted"
    )
    subdomain_processes: int | None = Field(
        None, ge=1, description="processes solving the sub-domains of one refinement level "
        "at once, per solve (1: one after the other); default: the cores left idle by "
        "`workers` solves, at least 1",
    )
    subdomains: Literal["local", "celery"] = Field(
        "local", description="where a solve's parallel sub-domains run: local, its own "
        "process pool; celery, tasks for `floorplan worker --subdomains` (celery backend; "
        "the local pool when no such worker is alive)",
    )
    api_keys: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="comma-separated keys; when set, every request needs one and sees only "
        "its own jobs",
    )

    allowed_hosts: Annotated[list[str] | None, NoDecode] = Field(
        None, description="comma-separated host names the service answers to (the Host "
        "header, without port, IPv6 in brackets; `*.example.com` for subdomains, `*` for "
        "any); other hosts "
        "get 400. Default: the loopback names when `host` is a loopback address (no DNS "
        "rebinding onto a local service), else any",
    )

    @field_validator("api_keys", "allowed_hosts", mode="before")
    @classmethod
    def _comma_separated(cls, value: Any) -> Any:
        if isinstance(value, str):
            return [key.strip() for key in value.split(",") if key.strip()]
        return value

    @property
    def trusted_hosts(self) -> list[str]:
        """`allowed_hosts`, or its default for the address the service listens on."""
        if self.allowed_hosts is not None:
            return self.allowed_hosts
        return list(LOOPBACK_NAMES) if _is_loopback(self.host) else ["*"]

    @property
    def database_path(self) -> Path:
        return self.data_dir / "jobs.sqlite3"

    @property
    def store_url(self) -> str:
        """The job store: FLOORPLAN_DATABASE_URL, else the SQLite file in data_dir."""
        if self.database_url:
            return self.database_url
        self.data_dir.mkdir(parents=True, exist_ok=True)
        return f"sqlite:///{self.database_path}"

    @property
    def subdomain_processes_per_solve(self) -> int:
        if self.subdomain_processes is not None:
            return self.subdomain_processes
        return max(1, (os.cpu_count() or 1) // self.workers)

    @property
    def heartbeat_seconds(self) -> float:
        """How often a worker renews its lease and looks for a cancel: a few times per
        lease, so one slow write does not cost a job."""
        return min(self.lease_seconds / 4, 5.0)


@lru_cache
def get_settings() -> Settings:
    return Settings()
