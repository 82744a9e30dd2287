#!/usr/bin/env bash
# Smoke test of compose.yaml: the whole stack builds the bundled light steel frame to completion.
#
#   1. docker, compose (`docker compose`, else `docker-compose`) and debootstrap must be installed
#      (`bash scripts/setup.sh --tests` installs them); dockerd is started when no daemon answers;
#   2. the image built with scripts/build-images.sh (a debootstrap base and a host wheelhouse: no registry);
#   3. `up -d` as a project of its own (bimbot-smoke-<pid>), the observer's ports on free loopback ports;
#   4. wait until the planner exits (it does once every task is settled), failing early when a service
#      crash-loops or the stack does not come up;
#   5. check: the planner exited 0 and said "all N component(s) constructed", every component of the
#      build's manifest answers "constructed" to a digital-twin query over the bus, and the observer still
#      serves its web viewer;
#   6. a summary with timings, then the logs and `down -v` (always, also on failure or interrupt; nothing is
#      checked after the logs, so the stack is stopped with a 1 s grace, not compose's 10 s).
#
# Usage: bash scripts/compose-smoke.sh
# Environment: BIMBOT_SMOKE_TIMEOUT_S (wait for the build, default 360), BIMBOT_SMOKE_BUDGET_S (the whole
#              script, image build included, default 540: the wait is cut short to keep within it),
#              BIMBOT_SMOKE_PROJECT (compose project, default bimbot-smoke-<pid>), BIMBOT_SMOKE_KEEP=1
#              (leave the stack up for a look), BIMBOT_FIDELITY (physics, the default, or plan: what
#              compose.yaml's physics and robots simulate; the test suite's smoke test runs plan).
# Exit codes: 0 all constructed, 1 failure, 2 usage, 3 docker cannot be used on this machine.
# Prints "compose-smoke: all N of N components constructed" on success. Logs: build/compose-smoke/.
set -euo pipefail
cd "$(dirname "$0")/.."

PROJECT="${BIMBOT_SMOKE_PROJECT:-bimbot-smoke-$$}"
TIMEOUT_S="${BIMBOT_SMOKE_TIMEOUT_S:-360}"
BUDGET_S="${BIMBOT_SMOKE_BUDGET_S:-540}"
KEEP="${BIMBOT_SMOKE_KEEP:-0}"
LOG_DIR=build/compose-smoke
MAX_RESTARTS=3 # a service restarted this often is crash-looping: fail now rather than at the timeout
CHECK_S=10     # how often the stack is looked at for a crash while the build runs (the planner's end: at once)
STOP_S=1       # grace for a container to stop at the teardown (see 6.)

say() { echo "compose-smoke: $*" >&2; }
fail() {
    say "FAILED: $*"
    exit 1
}
no_docker() {
    say "docker cannot be used here: $*"
    exit 3
}
if [ $# -gt 0 ]; then
    say "unknown argument: $1 (usage: bash scripts/compose-smoke.sh)"
    exit 2
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo -n" # no password prompt unless someone is there to answer it
    [ -t 0 ] && SUDO="sudo"
fi
started_all=$SECONDS

# ------------------------------------------------------------------------------ 1. packages and the daemon
missing=()
command -v docker >/dev/null || missing+=("docker (the client)")
# A client alone is not enough: without a daemon that answers, this script starts dockerd.
docker info >/dev/null 2>&1 || command -v dockerd >/dev/null || missing+=("dockerd (the engine)")
command -v debootstrap >/dev/null || missing+=(debootstrap)
if ! docker compose version >/dev/null 2>&1 && ! command -v docker-compose >/dev/null; then
    missing+=(docker-compose)
fi
((${#missing[@]} == 0)) || no_docker "${missing[*]} not installed (bash scripts/setup.sh --tests installs them)"
wait_for_docker() { # seconds [pid]; true once the daemon answers this user, false at once if pid exits
    local _
    for _ in $(seq "$1"); do
        docker info >/dev/null 2>&1 && return 0
        if [ -n "${2:-}" ] && ! kill -0 "$2" 2>/dev/null; then
            say "dockerd exited before it answered"
            return 1
        fi
        sleep 1
    done
    return 1
}
# shellcheck source=scripts/lib/pid-file.sh
source scripts/lib/pid-file.sh # (the working directory is the repository, see above)
if ! docker info >/dev/null 2>&1; then
    if { pidof dockerd || pgrep -x dockerd; } >/dev/null 2>&1; then
        say "dockerd runs but does not answer yet; waiting for it"
        wait_for_docker 30 || no_docker "dockerd runs but does not answer this user (not in the docker group?)"
    else
        remove_stale_pid_file /var/run/docker.pid dockerd
        # and the containerd dockerd starts: a reused pid there makes dockerd wait for it, then give up
        remove_stale_pid_file /var/run/docker/containerd/containerd.pid containerd
        say "starting dockerd (log: /tmp/bimbot-dockerd.log)"
        # setsid: the daemon outlives this script and whatever started it; it is left running afterwards.
        $SUDO setsid dockerd >/tmp/bimbot-dockerd.log 2>&1 </dev/null &
        dockerd_pid=$!
        wait_for_docker 60 "$dockerd_pid" || {
            tail -n 20 /tmp/bimbot-dockerd.log >&2 || true
            no_docker "dockerd did not start (log above: /tmp/bimbot-dockerd.log)"
        }
    fi
fi
if docker compose version >/dev/null 2>&1; then
    COMPOSE_TOOL=(docker compose)
else
    COMPOSE_TOOL=(docker-compose)
fi
say "using ${COMPOSE_TOOL[*]} $("${COMPOSE_TOOL[@]}" version --short 2>/dev/null || echo '(version unknown)')," \
    "docker server $(docker version -f '{{.Server.Version}}' 2>/dev/null || echo '(version unknown)')"
COMPOSE=("${COMPOSE_TOOL[@]}" --project-name "$PROJECT" --file compose.yaml)

# ------------------------------------------------------------------------------ 2. image
started=$SECONDS
bash scripts/build-images.sh
build_s=$((SECONDS - started))

# ------------------------------------------------------------------------------ 3. up
rm -rf "$LOG_DIR"
mkdir -p "$LOG_DIR"
free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
export BIMBOT_BUS_PORT BIMBOT_WEB_PORT BIMBOT_GRPC_PORT
BIMBOT_BUS_PORT="$(free_port)"
BIMBOT_WEB_PORT="$(free_port)"
BIMBOT_GRPC_PORT="$(free_port)"

container() { # the container id of a service (running or exited), empty when there is none
    docker ps -a -q --filter "label=com.docker.compose.project=$PROJECT" \
        --filter "label=com.docker.compose.service=$1" | head -n 1
}
STATE_FORMAT='{{.State.Status}} {{.State.ExitCode}} {{.RestartCount}} {{if .State.Health}}{{.State.Health.Status}}{{else}}-{{end}}'
container_state() { # status exit-code restarts health
    docker inspect -f "$STATE_FORMAT" "$1"
}
# One line per container of the project: service status exit-code restarts health. Two docker calls for all
# of them: the checks below run every 2 s on a machine that the stack keeps busy.
stack_states() {
    local ids
    ids="$(docker ps -a -q --filter "label=com.docker.compose.project=$PROJECT")"
    # shellcheck disable=SC2086  # one argument per id
    [ -z "$ids" ] || docker inspect -f "{{index .Config.Labels \"com.docker.compose.service\"}} $STATE_FORMAT" $ids
}
# compose.yaml's services, asked once (compose v1 is a Python program: seconds a call on a busy machine)
mapfile -t SERVICES < <("${COMPOSE[@]}" config --services)

summary() {
    local service states line
    states="$(stack_states)"
    say "services:"
    for service in "${SERVICES[@]}"; do
        line="$(awk -v s="$service" '$1 == s { print; exit }' <<<"$states")"
        if [ -n "$line" ]; then
            read -r _ status code restarts health <<<"$line"
            printf '  %-10s %-9s exit %-3s restarts %-2s health %s\n' "$service" "$status" "$code" "$restarts" \
                "$health" >&2
        else
            printf '  %-10s not created\n' "$service" >&2
        fi
    done
}

# Every container's log with its service's name, in time order, into compose.log: one `docker logs` per
# container, all at once (compose v1's `logs`, a Python program, took 9 s for this on a busy machine).
save_logs() {
    local parts id service pids=()
    parts="$(mktemp -d)"
    while read -r id service; do
        { docker logs --timestamps "$id" 2>&1 | sed "s/^/$service | /" >"$parts/$service"; } &
        pids+=($!)
    done < <(docker ps -a --filter "label=com.docker.compose.project=$PROJECT" \
        --format '{{.ID}} {{.Label "com.docker.compose.service"}}')
    ((${#pids[@]} == 0)) || wait "${pids[@]}"
    find "$parts" -type f -exec cat {} + | sort -s -k3,3 >"$LOG_DIR/compose.log"
    rm -rf "$parts"
}

cleanup() {
    local exit_code=$?
    trap - EXIT INT TERM
    [ -z "${waiter:-}" ] || kill "$waiter" 2>/dev/null || true
    save_logs || true
    if [ "$exit_code" -ne 0 ]; then
        summary || true
        say "last lines of every service (all of it: $LOG_DIR/compose.log):"
        "${COMPOSE[@]}" logs --no-color --tail=25 >&2 2>&1 || true
    fi
    if [ "$KEEP" = 1 ]; then
        say "stack left up (BIMBOT_SMOKE_KEEP=1): ${COMPOSE[*]} down -v"
    else
        say "tearing down"
        "${COMPOSE[@]}" down -v --remove-orphans --timeout "$STOP_S" >/dev/null 2>&1 \
            || say "warning: down -v failed"
    fi
    say "total $((SECONDS - started_all)) s"
    exit "$exit_code"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

"${COMPOSE[@]}" down -v --remove-orphans --timeout "$STOP_S" >/dev/null 2>&1 || true
# Stacks of earlier runs that were killed before their teardown (their script's process is gone).
for stale in $(docker ps -a --format '{{.Label "com.docker.compose.project"}}' | grep -E '^bimbot-smoke-[0-9]+$' | sort -u); do
    if [ "$stale" != "$PROJECT" ] && ! kill -0 "${stale#bimbot-smoke-}" 2>/dev/null; then
        say "removing $stale, left by an earlier run that did not finish"
        "${COMPOSE_TOOL[@]}" --project-name "$stale" --file compose.yaml down -v --remove-orphans \
            --timeout "$STOP_S" >/dev/null 2>&1 || true
    fi
done
started=$SECONDS
say "up: project $PROJECT, bus on 127.0.0.1:$BIMBOT_BUS_PORT, viewer on 127.0.0.1:$BIMBOT_WEB_PORT" \
    "(gRPC $BIMBOT_GRPC_PORT)"
# -d still waits for every depends_on condition (healthy bus, converted build, …) before starting a service.
"${COMPOSE[@]}" up -d >"$LOG_DIR/up.log" 2>&1 || {
    cat "$LOG_DIR/up.log" >&2
    fail "the stack did not come up"
}
up_s=$((SECONDS - started))
left_s=$((BUDGET_S - (SECONDS - started_all) - 20)) # 20 s for the checks and the teardown
[ "$left_s" -ge "$TIMEOUT_S" ] || TIMEOUT_S=$((left_s > 0 ? left_s : 0))
say "stack up in $up_s s; waiting up to $TIMEOUT_S s for the planner to finish"

# ------------------------------------------------------------------------------ 4. wait for the planner
started=$SECONDS
planner_code=""
next_report=30
next_check=0
planner="$(container planner)"
[ -n "$planner" ] || fail "no planner container"
# `docker wait` returns once the planner's container stops (it exits, or crashes before a restart): its end
# is seen at once without asking docker every second; the whole stack is looked at every CHECK_S.
docker wait "$planner" >/dev/null 2>&1 &
waiter=$!
while [ $((SECONDS - started)) -lt "$TIMEOUT_S" ]; do
    if kill -0 "$waiter" 2>/dev/null && [ $((SECONDS - started)) -lt "$next_check" ]; then
        sleep 1
        continue
    fi
    next_check=$((SECONDS - started + CHECK_S))
    states="$(stack_states)"
    read -r _ status code restarts _ <<<"$(awk '$1 == "planner" { print; exit }' <<<"$states")"
    [ -n "${status:-}" ] || fail "no planner container"
    if [ $((SECONDS - started)) -ge "$next_report" ]; then
        # the planner logs "<GlobalId> constructed" once for each component (its follow-up)
        done_so_far="$(docker logs "$planner" 2>&1 | grep -cE ' [0-9A-Za-z_$]{22} constructed$' || true)"
        say "… $((SECONDS - started)) s: $done_so_far component(s) constructed so far (planner's log)"
        next_report=$((next_report + 30))
    fi
    if [ "$restarts" -gt 0 ]; then
        fail "the planner failed (exit $code) and was restarted $restarts time(s)"
    fi
    if [ "$status" = exited ]; then
        planner_code="$code"
        break
    fi
    while read -r service s_status s_code s_restarts _; do
        if [ "$s_restarts" -ge "$MAX_RESTARTS" ]; then
            fail "$service is crash-looping (restarted $s_restarts times; its log is below)"
        fi
        if [ "$service" != convert ] && [ "$s_status" = exited ] && [ "$s_code" != 0 ]; then
            fail "$service stopped with exit $s_code"
        fi
    done <<<"$states"
    sleep 1
done
build_wait_s=$((SECONDS - started))
[ -n "$planner_code" ] || fail "the build did not finish within $TIMEOUT_S s"
say "planner exited $planner_code after $build_wait_s s"

# ------------------------------------------------------------------------------ 5. checks
docker logs "$planner" >"$LOG_DIR/planner.log" 2>&1 || true
[ "$planner_code" = 0 ] || fail "the planner reports failed or blocked components (exit $planner_code)"
grep -Eq "construction done: all [0-9]+ component\(s\) constructed" "$LOG_DIR/planner.log" \
    || fail "the planner exited 0 without reporting the construction done"

# Every component of the manifest, asked over the bus from inside the stack (its agent's twin record).
agents="$(container agents)"
[ -n "$agents" ] || fail "no agents container"
if ! docker exec -i "$agents" python - >"$LOG_DIR/twins.txt" 2>"$LOG_DIR/twins.err" <<'EOF'
import sys
from pathlib import Path

import zenoh

from bimbot.shared.bus import BusOptions, open_session
from bimbot.shared.manifest import read_manifest
from bimbot.shared.messages import COMPONENT_TWIN_KEY, ComponentState, TwinMsg, key

manifest = read_manifest("/data/build")
states = {}
# the secured bus: the read-only monitor's credentials (bimbot bus-credentials wrote them into the volume)
monitor = Path("/data/bus/monitor.json5")
with open_session(BusOptions(mode="client", connect=("tcp/bus:7447",), listen=(), config_file=monitor)) as session:
    selector = key(COMPONENT_TWIN_KEY, site=manifest.site, key="*")
    for reply in session.get(selector, target=zenoh.QueryTarget.ALL, timeout=10.0):
        if reply.ok is not None:
            twin = TwinMsg.model_validate_json(reply.ok.payload.to_bytes())
            states[twin.guid] = twin.state
total = len(manifest.components)
constructed = [c for c in manifest.components if states.get(c.guid) == ComponentState.CONSTRUCTED]
for component in manifest.components:
    print(f"{component.guid} {component.ifc_class} {states.get(component.guid, 'no answer')}")
print(f"{len(constructed)} {total}")
sys.exit(0 if total and len(constructed) == total else 1)
EOF
then
    cat "$LOG_DIR/twins.err" "$LOG_DIR/twins.txt" >&2
    fail "not every component is constructed"
fi
read -r constructed total <<<"$(tail -n 1 "$LOG_DIR/twins.txt")"

# The observer keeps serving after the build: its web viewer answers on the published loopback port.
observer="$(container observer)"
read -r o_status _ _ o_health <<<"$(container_state "$observer")"
[ "$o_status" = running ] || fail "the observer is not running after the build ($o_status)"
python3 -c "import sys, urllib.request; sys.exit(urllib.request.urlopen(sys.argv[1], timeout=10).status != 200)" \
    "http://127.0.0.1:$BIMBOT_WEB_PORT/" || fail "the web viewer does not answer on 127.0.0.1:$BIMBOT_WEB_PORT"

# ------------------------------------------------------------------------------ 6. summary
summary
say "timings: image build ${build_s} s, stack up ${up_s} s, construction ${build_wait_s} s" \
    "at fidelity ${BIMBOT_FIDELITY:-physics}" \
    "(total so far $((SECONDS - started_all)) s); observer ${o_status} (${o_health}), viewer answers"
echo "compose-smoke: all $constructed of $total components constructed"
