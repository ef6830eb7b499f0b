#!/usr/bin/env bash
# The distributed topology of docker-compose.yml from plain processes, for machines
# without a Docker engine: the local PostgreSQL and Redis (started when they are down),
# N Celery workers and one API node (uvicorn), all in the foreground. Ctrl-C or SIGTERM
# stops the workers first (they hand their running jobs back to the queue), then the API.
#
#   scripts/run-distributed.sh [--workers N] [--concurrency C] [--subdomain-workers S]
#                              [--host H] [--port P] [--logs DIR]
#
# --subdomain-workers S adds S workers (C at once each) for the independent sub-domains
# of refinement levels, which the solves then send out as Celery tasks.
#
# Settings come from FLOORPLAN_* variables as for `floorplan serve` (see the README);
# FLOORPLAN_BACKEND is celery here, and these defaults apply when unset:
#   FLOORPLAN_DATABASE_URL  postgresql+psycopg://root@127.0.0.1:5432/floorplan (made if missing)
#   FLOORPLAN_REDIS_URL     redis://127.0.0.1:6379/0
# Run it from the virtual environment where `pip install -e ".[distributed]"` was done
# (or name its interpreter in PYTHON).
set -euo pipefail

workers=2
concurrency=1
subdomain_workers=0
host=127.0.0.1
port=8000
logs=data/distributed-logs

usage() { sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'; }
while [[ $# -gt 0 ]]; do
  case "$1" in
    --workers) workers="$2"; shift 2 ;;
    --concurrency) concurrency="$2"; shift 2 ;;
    --subdomain-workers) subdomain_workers="$2"; shift 2 ;;
    --host) host="$2"; shift 2 ;;
    --port) port="$2"; shift 2 ;;
    --logs) logs="$2"; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    *) echo "run-distributed: unknown option $1" >&2; usage >&2; exit 2 ;;
  esac
done
for number in "$workers" "$concurrency" "$subdomain_workers" "$port"; do
  [[ "$number" =~ ^[0-9]+$ ]] || { echo "run-distributed: not a number: $number" >&2; exit 2; }
done

export FLOORPLAN_BACKEND=celery
export FLOORPLAN_DATABASE_URL="${FLOORPLAN_DATABASE_URL:-postgresql+psycopg://root@127.0.0.1:5432/floorplan}"
export FLOORPLAN_REDIS_URL="${FLOORPLAN_REDIS_URL:-redis://127.0.0.1:6379/0}"
export FLOORPLAN_WORKERS="$concurrency"
namespace="${FLOORPLAN_NAMESPACE:-floorplan}"
if [[ "$subdomain_workers" -gt 0 ]]; then
  export FLOORPLAN_SUBDOMAINS=celery
fi
python="${PYTHON:-$(command -v python || command -v python3)}"
mkdir -p "$logs"

# 1. The local services, started when down, with the machine notes' commands.
if [[ "$FLOORPLAN_DATABASE_URL" == *@127.0.0.1* || "$FLOORPLAN_DATABASE_URL" == *@localhost* ]] \
    && ! pg_isready -h 127.0.0.1 -p 5432 -q 2>/dev/null; then
  echo "run-distributed: starting PostgreSQL"
  pg_ctlcluster --skip-systemctl-redirect "$(ls /etc/postgresql)" main start
fi
if [[ "$FLOORPLAN_REDIS_URL" == redis://127.0.0.1:6379* || "$FLOORPLAN_REDIS_URL" == redis://localhost:6379* ]] \
    && ! redis-cli -h 127.0.0.1 -p 6379 ping >/dev/null 2>&1; then
  echo "run-distributed: starting Redis"
  redis-server --daemonize yes --bind 127.0.0.1 -::1 --port 6379 --save "" --appendonly no \
    --dir /var/lib/redis --logfile /var/log/redis/ci.log
fi

# 2. The database, made if missing, and its schema brought up to date (Alembic) once,
# before the nodes start.
"$python" - <<'PY'
import os

import psycopg
from sqlalchemy.engine import make_url

from service.store import JobStore

url = make_url(os.environ["FLOORPLAN_DATABASE_URL"])
if url.get_backend_name() == "postgresql" and url.database:
    admin = url.set(drivername="postgresql", database="postgres", query={})
    dsn = admin.render_as_string(hide_password=False)
    with psycopg.connect(dsn, autocommit=True) as conn:
        if not conn.execute("SELECT 1 FROM pg_database WHERE datname = %s",
                            (url.database,)).fetchone():
            conn.execute(f'CREATE DATABASE "{url.database}"')
            print(f"run-distributed: created database {url.database}")
JobStore(os.environ["FLOORPLAN_DATABASE_URL"]).engine.dispose()
PY

# 3. The workers and the API node.
worker_pids=()
api_pid=""
stop() {
  trap - INT TERM
  echo "run-distributed: stopping (workers hand their jobs back first)"
  for pid in "${worker_pids[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
  for pid in "${worker_pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  if [[ -n "$api_pid" ]]; then
    kill -TERM "$api_pid" 2>/dev/null || true
    wait "$api_pid" 2>/dev/null || true
  fi
}
trap 'stop; exit 0' INT TERM

for k in $(seq 1 "$workers"); do
  "$python" -m celery -A floorplan.service.jobs.celery.worker worker --pool threads --concurrency "$concurrency" \
    --queues "$namespace" --hostname "w$k@%h" --loglevel INFO \
    --without-gossip --without-mingle --without-heartbeat >>"$logs/worker-$k.log" 2>&1 &
  worker_pids+=("$!")
done
for k in $(seq 1 "$subdomain_workers"); do
  "$python" -m celery -A floorplan.service.jobs.celery.worker worker --pool prefork --concurrency "$concurrency" \
    --queues "$namespace.subdomains" --hostname "s$k@%h" --loglevel INFO \
    --without-gossip --without-mingle --without-heartbeat >>"$logs/subdomain-worker-$k.log" 2>&1 &
  worker_pids+=("$!")
done
"$python" -m uvicorn floorplan.service.api.app:create_app --factory --host "$host" --port "$port" \
  --timeout-graceful-shutdown 5 >>"$logs/api.log" 2>&1 &
api_pid="$!"

# 4. Ready once the API answers and every worker has said it is alive.
for _ in $(seq 1 600); do
  if "$python" - "$host" "$port" "$workers" <<'PY' 2>/dev/null; then
import json
import os
import sys
import urllib.request

host, port, workers = sys.argv[1], sys.argv[2], int(sys.argv[3])
# With API keys set, /readyz shows its figures (live workers) only to a valid key.
keys = [k.strip() for k in os.environ.get("FLOORPLAN_API_KEYS", "").split(",") if k.strip()]
request = urllib.request.Request(f"http://{host}:{port}/readyz", headers=(
    {"Authorization": f"Bearer {keys[0]}"} if keys else {}))
with urllib.request.urlopen(request, timeout=2) as answer:
    sys.exit(0 if json.load(answer).get("workers", 0) >= workers else 1)
PY
    echo "run-distributed: ready at http://$host:$port with $workers workers x $concurrency solves and $subdomain_workers sub-domain workers (logs in $logs)"
    break
  fi
  for pid in "$api_pid" "${worker_pids[@]}"; do
    if ! kill -0 "$pid" 2>/dev/null; then
      echo "run-distributed: a process exited during startup; see $logs" >&2
      stop
      exit 1
    fi
  done
  sleep 0.1
done

# 5. Run until stopped, or until a process dies (then stop the rest, and say so).
set +e
wait -n "$api_pid" "${worker_pids[@]}"
echo "run-distributed: a process exited; stopping the others (see $logs)" >&2
stop
exit 1
