"""The converted bundled light steel frame (28 components) and a factory of fresh simulations of it."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path

import pytest

from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.manifest import Manifest, read_manifest


@pytest.fixture(scope="session")
def frame_manifest(bundled_build: Path) -> Manifest:
    return read_manifest(bundled_build)


@pytest.fixture
def make_sim(bundled_build: Path, frame_manifest: Manifest) -> Iterator[Callable[..., Simulation]]:
    """``make_sim(robots=1, odom_noise=0.0, …)``: a fresh DIRECT simulation (of ``manifest=``, a variant of
    the frame, when given), closed after the test."""
    with ExitStack() as stack:

        def make(manifest: Manifest | None = None, **overrides: object) -> Simulation:
            config = SimConfig(**{"odom_noise": 0.0, **overrides})  # type: ignore[arg-type]
            return stack.enter_context(Simulation(manifest or frame_manifest, bundled_build, config))

        yield make
