"""``bimbot convert`` of every public sample model ends with its documented exit code, never a traceback.

Exit codes (services/converter/cli.py): 0 converted, 1 read but nothing to convert (one line saying so:
geographic-referencing.ifc holds one proxy without triangulated geometry), 2 unreadable. The Revit
restaurant (revit2012_janesville_restaurant.zip, ~830 components) is left out: it converts in about three
minutes on two cores (exit 0, 318 joints, 632 clashes); it once ended in a precedence cycle, which
tests/shared/test_support_graph.py reproduces in a few components.

The conversions are the ones every sample test reads (tests/sample_builds.py: the command's ``main`` with its
defaults, once per test run), so each sample is converted once, not once more here.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from sample_builds import sample_conversion_ended

from bimbot.cli import BUG_MARK

EXPECTED_EXIT = {"geographic-referencing.ifc": 2}  # a proxy without triangulated geometry: unusable input


def test_every_sample_converts_without_a_traceback(
    samples_dir: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    models = sorted(samples_dir.glob("*.ifc"))
    assert models
    ended = {model.name: sample_conversion_ended(model.name, tmp_path_factory) for model in models}
    for name, how in ended.items():
        assert BUG_MARK not in how.log and "Traceback" not in how.log, (name, how.log)
        assert how.stdout.startswith("converted "), (name, how.stdout)  # the summary line
    assert {name: how.code for name, how in ended.items()} == {
        model.name: EXPECTED_EXIT.get(model.name, 0) for model in models
    }
