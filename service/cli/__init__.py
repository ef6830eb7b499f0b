"""The `floorplan` command: the solver's subcommands plus `serve` and `worker` (and
`submit`, from the Python client, when it is installed). The solve command is solve.py,
with progress.py (what it prints), interrupt.py (Ctrl-C) and exits.py (exit codes)."""

from __future__ import annotations

import argparse
from typing import Any

from floorplan.service.cli import solve as solver_cli

#: What to do when the distributed mode's packages are missing (the project's name on
#: PyPI is floorplan-miqp; "floorplan" is another project).
DISTRIBUTED_HINT = ("floorplan worker needs the distributed extra "
                    "(pip install 'floorplan-miqp[distributed]'): {}")


def add_serve(commands: Any) -> None:
    p = commands.add_parser(
        "serve",
        help="run the HTTP service (by default jobs in SQLite, solved here; no other server "
        "needed)",
        description="Serve the layout API. Settings come from FLOORPLAN_* environment "
        "variables or .env (see the README); these options override them.",
    )
    p.add_argument("--host", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, help="port (default 8000)")
    p.add_argument("--workers", type=int, help="solves at once (default: the number of cores)")
    p.add_argument("--data-dir", help="where the job store lives (default ./data)")
    p.add_argument("--log-level", default="info", help="uvicorn log level")
    p.set_defaults(func=cmd_serve, own_signals=True)


def add_worker(commands: Any) -> None:
    p = commands.add_parser(
        "worker",
        help="run a Celery worker of the distributed mode (needs the `distributed` extra)",
        description="Solve jobs queued by `floorplan serve` nodes running with "
        "FLOORPLAN_BACKEND=celery: a Celery worker (threads pool) whose every solve runs in "
        "its own process. Settings come from FLOORPLAN_* variables or .env, as for serve.",
    )
    p.add_argument("--workers", type=int, help="solves at once (default: the number of cores)")
    p.add_argument("--hostname", help="the worker's Celery node name (default celery@HOST); "
                   "give each worker on one machine its own")
    p.add_argument("--log-level", default="info", help="Celery log level")
    p.add_argument("--subdomains", action="store_true",
                   help="solve the sub-domains that solves send out (FLOORPLAN_SUBDOMAINS="
                   "celery) rather than jobs; --workers of them at once")
    p.add_argument("--health", action="store_true",
                   help="do not run a worker: exit 0 if one of this host is alive, else 1 "
                   "(a container health check)")
    p.set_defaults(func=cmd_worker, own_signals=True)


def cmd_worker(args: argparse.Namespace) -> int:
    from floorplan.service.settings import Settings

    overrides = {"workers": args.workers} if args.workers is not None else {}
    if args.health:  # the containers' light check (standard library only)
        from floorplan.service.jobs.broker.health import worker_alive

        settings = Settings(**overrides)
        alive = worker_alive(settings.redis_url, settings.namespace, subdomains=args.subdomains)
        return 0 if alive else 1
    try:
        from floorplan.service.jobs.celery.worker import run_worker
    except ModuleNotFoundError as err:
        raise SystemExit(DISTRIBUTED_HINT.format(err)) from err
    settings = Settings(**overrides)
    return run_worker(settings, hostname=args.hostname, loglevel=args.log_level.upper(),
                      subdomains=args.subdomains)


def cmd_serve(args: argparse.Namespace) -> int:
    import uvicorn

    from floorplan.service.api.app import create_app
    from floorplan.service.settings import Settings

    overrides = {k: v for k, v in {"host": args.host, "port": args.port,
                                   "workers": args.workers, "data_dir": args.data_dir}.items()
                 if v is not None}
    settings = Settings(**overrides)
    uvicorn.run(create_app(settings), host=settings.host, port=settings.port,
                log_level=args.log_level, timeout_graceful_shutdown=int(settings.grace_seconds))
    return 0


def main(argv: list[str] | None = None) -> int:
    from floorplan.service.cli.batch import add_batch

    extra: list[solver_cli.CommandAdder] = [add_batch, add_serve, add_worker]
    try:  # `floorplan submit` comes with the Python client (clients/python), when installed
        from floorplan_client.cli import add_submit
    except ModuleNotFoundError as err:
        if err.name != "floorplan_client":
            raise
    else:
        extra.append(add_submit)
    return solver_cli.main(argv, extra=extra)
