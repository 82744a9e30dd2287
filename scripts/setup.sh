#!/usr/bin/env bash
# Set up bimbot on a fresh Debian/Ubuntu machine: system packages, a virtual environment, the project.
# Idempotent: a second run only checks. Usage: bash scripts/setup.sh [--tests]
#   --tests  also what the test suite needs beyond the demo: the SDFormat reference parser and chromium,
#            the Docker engine (dockerd), compose and
#            debootstrap for the compose smoke test (tests/compose; scripts/compose-smoke.sh starts dockerd),
#            and Xvfb (xvfb-run, xauth) for the dashboard test's real browser window
#            (tests/observer/test_dashboard_browser.py)
set -euo pipefail
cd "$(dirname "$0")/.."

TESTS=0
for argument in "$@"; do
    case "$argument" in
        --tests) TESTS=1 ;;
        *)
            echo "setup: unknown argument: $argument (usage: bash scripts/setup.sh [--tests])" >&2
            exit 2
            ;;
    esac
done

missing=()
if [ "$TESTS" -eq 1 ]; then
    # For the tests only (the demo needs none of them): the SDFormat reference parser (`ign sdf -k`, to
    # validate every SDF) and Debian's chromium (headless, to test that the rerun web viewer page loads).
    for package in ignition-tools libsdformat-dev chromium; do
        dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
    done
    # Checked by the binary each step of the compose test runs, not by package name: a Docker client alone
    # (a static /usr/local/bin/docker, say) runs no daemon, and scripts/compose-smoke.sh starts `dockerd`.
    # The engine comes from Docker's own packages where they are installed or their repository is
    # configured (Debian's docker.io conflicts with docker-ce and docker-ce-cli), else from Debian.
    if ! command -v dockerd >/dev/null; then
        if dpkg-query -W -f='${Status}' docker-ce-cli 2>/dev/null | grep -q "install ok installed" \
            || apt-cache policy docker-ce 2>/dev/null | grep -q 'Candidate: [0-9]'; then
            missing+=(docker-ce containerd.io)
        else
            missing+=(docker.io)
        fi
    fi
    if ! docker compose version >/dev/null 2>&1 && ! command -v docker-compose >/dev/null; then
        if apt-cache policy docker-compose-plugin 2>/dev/null | grep -q 'Candidate: [0-9]'; then
            missing+=(docker-compose-plugin)
        else
            missing+=(docker-compose)
        fi
    fi
    command -v debootstrap >/dev/null || missing+=(debootstrap)
    command -v xvfb-run >/dev/null || missing+=(xvfb)
    command -v xauth >/dev/null || missing+=(xauth)
fi
if ((${#missing[@]})); then
    echo "setup: installing system packages: ${missing[*]}" >&2
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# Python environment with the pinned dependencies and the project itself (editable).
PYTHON="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
    echo "setup: creating .venv with $("$PYTHON" --version)" >&2
    "$PYTHON" -m venv .venv
fi
# pip warns "Location 'file:///…/simple/<package>/' is ignored: it is neither a file nor a directory" for
# every package a local index lacks: a machine whose pip configuration (pip config list: a user's or the
# system's pip.conf, PIP_EXTRA_INDEX_URL) names file:// indexes that each hold a few packages gets one line
# per package and index. Only those lines are dropped; pip's other output, and its exit status (pipefail),
# are kept.
IGNORED_LOCATION="^WARNING: Location 'file:[^']*' is ignored: it is neither a file nor a directory\.\$"
pip_quietly() {
    { .venv/bin/python -m pip "$@" 2>&1 1>&3 3>&- | { grep -v -E "$IGNORED_LOCATION" || true; } >&2; } 3>&1
}
if ! .venv/bin/python -c "import bimbot, ifcopenshell, zenoh, pybullet, rerun, trimesh" 2>/dev/null \
    || [ pyproject.toml -nt .venv/.bimbot-installed ]; then
    echo "setup: installing bimbot and its pinned dependencies into .venv" >&2
    pip_quietly install -q --disable-pip-version-check --upgrade pip
    # setuptools prints a boxed "Editable installation" warning about package-named folders in the working
    # directory; bimbot maps services/ and shared/ into its package and every service starts with
    # `python -P` (no working directory on sys.path), so the warning says nothing a user can act on
    PYTHONWARNINGS="ignore:Editable installation" \
        pip_quietly install -q --disable-pip-version-check -e '.[test]'
    touch .venv/.bimbot-installed
fi
echo "setup: ready ($(.venv/bin/bimbot --version 2>/dev/null || echo bimbot))" >&2
