#!/usr/bin/env bash
# Build the bimbot container image (bimbot:latest) on a machine that reaches no image registry.
#
#   1. base image  bimbot-base:bookworm  debootstrap (bookworm, minbase) + python3, python3-venv,
#                                        ca-certificates, turned into an image with `docker import`;
#                                        skipped when the tag exists (--rebuild-base forces it)
#   2. wheelhouse  build/wheelhouse/     wheels of every pinned dependency in pyproject.toml and of its
#                                        build backend, made on this host with `pip wheel`; fetched again
#                                        only when the pins change (the project itself is built in the image)
#   3. image       bimbot:latest         docker build --build-arg BASE_IMAGE=bimbot-base:bookworm
#                                                     --build-arg WHEELHOUSE=build/wheelhouse .
#                                        (its install stages tagged bimbot-build:project; images of
#                                        earlier builds pruned)
#
# Elsewhere, with a registry, none of this is needed: `docker compose build` uses python:3.11-slim-bookworm
# and PyPI. The wheels are built for this host's CPython, which must be 3.11 like the image's.
#
# Usage: bash scripts/build-images.sh [--rebuild-base]
# Environment: BIMBOT_BASE_IMAGE (bimbot-base:bookworm), BIMBOT_IMAGE (bimbot:latest),
#              DEBIAN_MIRROR (http://deb.debian.org/debian), PYTHON (the project's .venv, else python3).
# Idempotent; prints what it does and how long each step took on stderr.
set -euo pipefail
cd "$(dirname "$0")/.."

BASE_IMAGE="${BIMBOT_BASE_IMAGE:-bimbot-base:bookworm}"
IMAGE="${BIMBOT_IMAGE:-bimbot:latest}"
MIRROR="${DEBIAN_MIRROR:-http://deb.debian.org/debian}"
SUITE=bookworm
# What the wheels need at import time beyond minbase: libstdc++6 and zlib1g come with minbase (apt needs
# them); pybullet (DIRECT), ifcopenshell, rerun, zenoh, numba/llvmlite and manifold3d bundle the rest.
BASE_PACKAGES=python3,python3-venv,ca-certificates
WORK_DIR=build/docker                 # debootstrap's package cache (build/ is git-ignored)
WHEELHOUSE=build/wheelhouse           # inside the build context, relative to it (see .dockerignore)
REBUILD_BASE=0

for argument in "$@"; do
    case "$argument" in
        --rebuild-base) REBUILD_BASE=1 ;;
        -h | --help)
            sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'
            exit 0
            ;;
        *)
            echo "build-images: unknown argument: $argument (see --help)" >&2
            exit 2
            ;;
    esac
done

say() { echo "build-images: $*" >&2; }
die() {
    say "error: $*"
    exit 1
}
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"

docker info >/dev/null 2>&1 || die "docker is not usable (is dockerd running? try: sudo dockerd &)"

if [ -n "${PYTHON:-}" ]; then
    HOST_PYTHON="$PYTHON"
elif [ -x .venv/bin/python ]; then
    HOST_PYTHON=.venv/bin/python
else
    HOST_PYTHON=python3
fi
host_version="$("$HOST_PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
[ "$host_version" = "3.11" ] || die "$HOST_PYTHON is Python $host_version; the wheelhouse needs 3.11 (set PYTHON=)"

# ---------------------------------------------------------------------------------------------- base image
build_base_image() {
    command -v debootstrap >/dev/null || die "debootstrap is missing (apt-get install debootstrap)"
    local rootfs started
    started=$SECONDS
    mkdir -p "$WORK_DIR/debootstrap-cache"
    rootfs="$(mktemp -d /tmp/bimbot-rootfs.XXXXXX)"
    # shellcheck disable=SC2064  # expand now: the trap must remove this very folder
    trap "$SUDO rm -rf '$rootfs'" EXIT
    say "debootstrap $SUITE (minbase + $BASE_PACKAGES) from $MIRROR into $rootfs"
    $SUDO debootstrap --variant=minbase --include="$BASE_PACKAGES" \
        --cache-dir="$(realpath "$WORK_DIR/debootstrap-cache")" "$SUITE" "$rootfs" "$MIRROR" >"$rootfs.log" 2>&1 \
        || {
            tail -n 30 "$rootfs.log" >&2
            die "debootstrap failed (full log: $rootfs.log)"
        }
    rm -f "$rootfs.log"
    # An image needs no package lists, downloaded packages, documentation or locales.
    $SUDO rm -rf "$rootfs"/var/lib/apt/lists/* "$rootfs"/var/cache/apt/*.bin "$rootfs"/var/cache/apt/archives/*.deb \
        "$rootfs"/usr/share/doc/* "$rootfs"/usr/share/man/* "$rootfs"/usr/share/info/* "$rootfs"/usr/share/locale/* \
        "$rootfs"/var/log/*.log "$rootfs"/var/log/apt/* "$rootfs"/tmp/*
    say "importing the root file system as $BASE_IMAGE"
    $SUDO tar -C "$rootfs" --numeric-owner -c . | docker import \
        --change 'ENV LANG=C.UTF-8' \
        --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
        --change 'CMD ["/bin/bash"]' \
        --message "debootstrap $SUITE minbase + $BASE_PACKAGES" \
        - "$BASE_IMAGE" >/dev/null
    $SUDO rm -rf "$rootfs"
    trap - EXIT
    say "base image $BASE_IMAGE built in $((SECONDS - started)) s ($(image_size "$BASE_IMAGE"))"
}

image_size() {
    docker image inspect -f '{{.Size}}' "$1" | awk '{ printf "%.0f MB", $1 / 1e6 }'
}

if [ "$REBUILD_BASE" -eq 0 ] && docker image inspect "$BASE_IMAGE" >/dev/null 2>&1; then
    say "base image $BASE_IMAGE exists ($(image_size "$BASE_IMAGE")); skipped (--rebuild-base rebuilds it)"
else
    build_base_image
fi

# ---------------------------------------------------------------------------------------------- wheelhouse
started=$SECONDS
mkdir -p "$WHEELHOUSE"
requirements="$WHEELHOUSE/requirements.txt"
# The pinned runtime dependencies and the build backend's requirements, straight from pyproject.toml.
"$HOST_PYTHON" - >"$requirements.new" <<'EOF'
import tomllib

with open("pyproject.toml", "rb") as file:
    project = tomllib.load(file)
for requirement in [*project["build-system"]["requires"], *project["project"]["dependencies"]]:
    print(requirement)
EOF
PIP=("$HOST_PYTHON" -m pip --disable-pip-version-check)
wheelhouse_complete() { # every pin (and what it needs) resolves from the wheelhouse alone
    "${PIP[@]}" install -q --dry-run --ignore-installed --no-index --find-links "$WHEELHOUSE" \
        -r "$requirements" >/dev/null 2>&1
}
# What the last resolution found complete: the pins and the wheels' names and sizes. While both are the same,
# the wheelhouse is not resolved again (pip takes seconds for that, more on a busy machine).
stamp="$WHEELHOUSE.complete" # beside the wheelhouse: not in the build context (.dockerignore)
wheelhouse_listing() { cat "$requirements.new" && find "$WHEELHOUSE" -maxdepth 1 -name '*.whl' -printf '%f %s\n' | sort; }
if [ -f "$requirements" ] && cmp -s "$requirements" "$requirements.new" \
    && { cmp -s "$stamp" <(wheelhouse_listing) || wheelhouse_complete; }; then
    say "wheelhouse $WHEELHOUSE is current with pyproject.toml's pins"
else
    cp "$requirements.new" "$requirements"
    say "filling $WHEELHOUSE with wheels of the pinned dependencies ($(wc -l <"$requirements") pins + theirs)"
    "${PIP[@]}" wheel -q --wheel-dir "$WHEELHOUSE" --find-links "$WHEELHOUSE" -r "$requirements"
    wheelhouse_complete || die "the wheelhouse still misses wheels after pip wheel"
fi
# No project wheel here: the Dockerfile installs the project from the build context in a layer of its own
# (built offline with the wheelhouse's setuptools), so a source change does not reinstall the dependencies.
rm -f "$WHEELHOUSE"/bimbot-*.whl
wheelhouse_listing >"$stamp"
rm -f "$requirements.new"
say "wheelhouse ready in $((SECONDS - started)) s: $(find "$WHEELHOUSE" -name '*.whl' | wc -l) wheels," \
    "$(du -sh "$WHEELHOUSE" | cut -f1)"

# ---------------------------------------------------------------------------------------------- image
started=$SECONDS
say "docker build -t $IMAGE (FROM $BASE_IMAGE, wheels from $WHEELHOUSE)"
build_args=(--build-arg BASE_IMAGE="$BASE_IMAGE" --build-arg WHEELHOUSE="$WHEELHOUSE")
# The install stages are tagged too (bimbot-build:project), so that the superseded ones can be pruned
# below without losing the layer cache of the current ones (an untagged stage image would be pruned with
# its whole chain, dependencies included).
docker build "${build_args[@]}" --target project -t bimbot-build:project . >&2
docker build "${build_args[@]}" -t "$IMAGE" . >&2
# What earlier builds left: images this tag or the stage tag pointed to, now untagged and unused.
docker image prune -f --filter "label=org.opencontainers.image.title=bimbot" >/dev/null
docker image prune -f --filter "label=bimbot.stage" >/dev/null
say "image $IMAGE built in $((SECONDS - started)) s ($(image_size "$IMAGE"))"
