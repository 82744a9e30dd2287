# Sourced by scripts that start a daemon (compose-smoke.sh starts dockerd).
#
# A daemon killed without cleaning up (a machine or container stopped under it) leaves its pid file, and
# once that pid is reused by another process dockerd refuses to start ("pid file found"), or waits for the
# containerd it thinks it has and gives up. A pid file whose process is not the daemon named is stale:
# remove it.
remove_stale_pid_file() { # path daemon-name
    local pid
    [ -f "$1" ] || return 0
    pid=$(tr -dc '0-9' <"$1")
    if [ -n "$pid" ] && [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$2" ]; then
        return 0
    fi
    echo "removing $1: stale, left by a $2 that no longer runs (pid ${pid:-none})" >&2
    ${SUDO:-} rm -f "$1"
}
