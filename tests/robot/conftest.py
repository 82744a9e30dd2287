"""The robot tests' shared site: the site model's frame and a room of four walls round ``Column R1``."""

from __future__ import annotations

import pytest
from site_models import build_site_model

from bimbot.services.converter.convert import convert_model
from bimbot.shared.manifest import Manifest, read_manifest


@pytest.fixture(scope="session")
def room(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    """The site model's frame and a room of four walls around ``Column R1`` (no heavy footing), converted
    once for every robot test that walls a robot or a target in."""
    folder = tmp_path_factory.mktemp("room")
    model = build_site_model(heavy=None, room=True, furniture=False)
    source = model.write(folder / "site.ifc")
    convert_model(model.file, source, folder / "build")
    return read_manifest(folder / "build")
