# bimbot: one image for every service (`bimbot bus|convert|physics|agents|planner|robot|observe`).
#
# Elsewhere:  docker build -t bimbot:latest .             python:3.11-slim-bookworm, packages from PyPI
# Offline:    bash scripts/build-images.sh                a debootstrap base image and a host-built wheelhouse:
#             --build-arg BASE_IMAGE=bimbot-base:bookworm --build-arg WHEELHOUSE=build/wheelhouse
#
# BASE_IMAGE must provide python3 3.11 with its venv module. WHEELHOUSE is a folder of wheels inside the
# build context with every pinned dependency and the build backend (setuptools, wheel); empty: use PyPI.
# .dockerignore lets only build/wheelhouse/ through, so that is the folder to use.
#
# Stages: `deps` (a venv with the pinned dependencies, rebuilt only when pyproject.toml or the wheelhouse
# change), `project` (bimbot installed into it), and the runtime image, which takes the venv from `deps`
# and only bimbot's own files from `project`: a source change rebuilds a few MB, not the 1.8 GB venv, and
# neither the wheelhouse nor the sources reach the image.
ARG BASE_IMAGE=python:3.11-slim-bookworm

# ------------------------------------------------------------------------------------------ deps
FROM ${BASE_IMAGE} AS deps
LABEL bimbot.stage=build
ARG WHEELHOUSE=
ENV PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_CACHE_DIR=1 PIP_ROOT_USER_ACTION=ignore
# Without a wheelhouse the second source is pyproject.toml again, so nothing else is copied.
COPY pyproject.toml ${WHEELHOUSE:-pyproject.toml} /src/wheels/
RUN set -eu; \
    python3 -m venv /opt/bimbot; \
    python3 -c 'import tomllib; print("\n".join(tomllib.load(open("/src/wheels/pyproject.toml", "rb"))["project"]["dependencies"]))' \
        > /src/requirements.txt; \
    if [ -n "$WHEELHOUSE" ]; then \
        /opt/bimbot/bin/pip install -q --no-index --find-links /src/wheels -r /src/requirements.txt; \
    else \
        /opt/bimbot/bin/pip install -q -r /src/requirements.txt; \
    fi; \
    # Not needed at run time: setuptools, pybullet's example environments, the packages' own test suites.
    /opt/bimbot/bin/pip uninstall -y -q setuptools; \
    site=$(/opt/bimbot/bin/python -c 'import sysconfig; print(sysconfig.get_path("purelib"))'); \
    rm -rf "$site/pybullet_envs"; \
    find "$site" -mindepth 2 -type d -name tests -prune -exec rm -rf {} +

# ------------------------------------------------------------------------------------------ project
FROM deps AS project
ARG WHEELHOUSE=
COPY pyproject.toml README.md /src/project/
COPY bimbot /src/project/bimbot
COPY services /src/project/services
COPY shared /src/project/shared
# The build backend goes into this stage's venv and the project is built there, without pip's isolated
# build environment (made anew for every build: 6 of 10 s); the runtime image takes the venv from `deps`,
# so the backend does not reach it.
RUN set -eu; \
    /opt/bimbot/bin/python -c 'import tomllib; print("\n".join(tomllib.load(open("/src/project/pyproject.toml", "rb"))["build-system"]["requires"]))' \
        > /src/build-requirements.txt; \
    if [ -n "$WHEELHOUSE" ]; then \
        /opt/bimbot/bin/pip install -q --no-index --find-links /src/wheels -r /src/build-requirements.txt; \
        /opt/bimbot/bin/pip install -q --no-deps --no-build-isolation --no-index /src/project; \
    else \
        /opt/bimbot/bin/pip install -q -r /src/build-requirements.txt; \
        /opt/bimbot/bin/pip install -q --no-deps --no-build-isolation /src/project; \
    fi; \
    /opt/bimbot/bin/pip check; \
    # bimbot's own files (its RECORD: packages, byte code, metadata, the console script) under /overlay.
    mkdir -p /overlay; \
    /opt/bimbot/bin/python -c 'import importlib.metadata as m; print("\n".join(str(f.locate().resolve()) for f in m.distribution("bimbot").files))' \
        > /src/bimbot-files.txt; \
    xargs -d '\n' cp -a --parents -t /overlay < /src/bimbot-files.txt; \
    test -x /overlay/opt/bimbot/bin/bimbot; \
    # The bundled model at a fixed path, for `bimbot convert` in compose.yaml.
    model=$(/opt/bimbot/bin/python -c 'import importlib.resources as r; print(r.files("bimbot") / "data" / "light_steel_frame.ifc")'); \
    mkdir -p /overlay/opt/bimbot/share; \
    ln -s "$model" /overlay/opt/bimbot/share/light_steel_frame.ifc

# ------------------------------------------------------------------------------------------ runtime
FROM ${BASE_IMAGE}
LABEL org.opencontainers.image.title="bimbot" \
      org.opencontainers.image.description="IFC building models turned into robot construction simulations"
# A non-root user; /data (compose's volume: the converted build, journals, reports) belongs to it, and a
# new named volume mounted there takes that ownership.
RUN groupadd --gid 10001 bimbot \
    && useradd --uid 10001 --gid bimbot --create-home --home-dir /home/bimbot --shell /usr/sbin/nologin bimbot \
    && mkdir -p /data \
    && chown bimbot:bimbot /data
COPY --from=deps /opt/bimbot /opt/bimbot
COPY --from=project /overlay/ /
# Numba caches compiled kernels (the A* search) beside their module unless told otherwise, and the venv is
# read-only for the bimbot user: the caches go to its home.
ENV PATH=/opt/bimbot/bin:$PATH \
    PYTHONUNBUFFERED=1 \
    NUMBA_CACHE_DIR=/home/bimbot/.cache/numba \
    MPLCONFIGDIR=/home/bimbot/.cache/matplotlib \
    BIMBOT_MODEL=/opt/bimbot/share/light_steel_frame.ifc
USER bimbot
# The rerun CLI would print its analytics notice in every new container (and report usage from each).
# The compiled kernels (a robot's A* and laser model, physics' laser caster) are compiled here, into the
# image's numba cache: a container loads them instead of compiling them at its first tick.
RUN python -m rerun_cli analytics disable >/dev/null 2>&1 \
    && test -s "$BIMBOT_MODEL" \
    && bimbot --version \
    && python -c "from bimbot.services.robot.compiled_kernels import warm_up_kernels; warm_up_kernels(); \
        from bimbot.services.physics.ray_kernel import warm_up; warm_up()"
WORKDIR /data
ENTRYPOINT ["bimbot"]
CMD ["--help"]
