"""``bimbot run OUT/ --check-stability``: a physics-only replay of the sequence says whether every partial
structure stands, or names the first step that does not, the component, how far it moved, what it was set
down on and what it rests on that was not there; in seconds, without robots."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from wall_clock import bound_s

from bimbot.shared.manifest import Manifest, read_manifest, write_manifest
from bimbot.shared.sequence import read_sequence, sequence_from_predecessors, write_sequence


def _check(build: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-P", "-m", "bimbot.cli", "run", str(build), "--check-stability", *extra],
        capture_output=True,
        text=True,
        timeout=bound_s(120),
        check=False,
    )


def _reordered(build: Path, manifest: Manifest, tmp_path: Path, move: str, after: str | None) -> Path:
    """The build's sequence as a plain chain with component ``move`` put right after ``after`` (first when
    None): a schedule a user might write."""
    guid = {c.name: c.guid for c in manifest.components}
    order = [g for g in read_sequence(build / "sequence.xml").guids() if g != guid[move]]
    order.insert(0 if after is None else order.index(guid[after]) + 1, guid[move])
    chain = {g: {order[i - 1]} for i, g in enumerate(order) if i}
    return write_sequence(sequence_from_predecessors(order, chain, source="user"), tmp_path / "bad.xml")


def test_the_bundled_schedule_stands_at_every_step(bundled_build: Path) -> None:
    started = time.monotonic()
    result = _check(bundled_build)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "every partial structure stands: 28 step(s)" in result.stdout
    assert time.monotonic() - started < bound_s(60.0)  # seconds, not a build (0.3 s of physics here)


def test_without_connections_the_bundled_frame_still_stands_and_the_check_says_so(
    bundled_build: Path,
) -> None:
    """Every member of the bundled frame rests on what is under it: it needs no connection."""
    result = _check(bundled_build, "--no-connections")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "without connections: every component must stand by itself" in result.stdout
    assert "every partial structure stands: 28 step(s)" in result.stdout


def test_a_beam_on_a_single_column_stands_on_props_and_the_check_names_them(
    bundled_build: Path, tmp_path: Path
) -> None:
    """Set before its second column, a beam is bolted at one end only (a hinge): its build says it is
    propped until connected, so the step stands on two props and the check names them."""
    manifest = read_manifest(bundled_build)
    bad = _reordered(bundled_build, manifest, tmp_path, "Beam A1-A2", after="Column A1")
    result = _check(bundled_build, "--sequence", str(bad))
    assert result.returncode == 0, result.stdout + result.stderr
    assert "1 step(s) need temporary supports (2 in all)" in result.stdout
    assert "step 11: Beam A1-A2" in result.stdout and "needs 2 props" in result.stdout


def test_without_props_a_beam_on_a_single_column_is_the_step_that_does_not_stand(
    bundled_build: Path, tmp_path: Path
) -> None:
    """The same order in a build that gives the beam no temporary support: one pinned end does not hold
    it, it tips off Column A1, and the check stops there and says what to place first."""
    build = tmp_path / "build"
    shutil.copytree(bundled_build, build)
    manifest = read_manifest(build)
    bare = [c.model_copy(update={"temporary_support": None}) for c in manifest.components]
    manifest = manifest.model_copy(update={"components": bare})
    write_manifest(manifest, build)
    names = {c.name: c.guid for c in manifest.components}
    bad = _reordered(build, manifest, tmp_path, "Beam A1-A2", after="Column A1")
    result = _check(build, "--sequence", str(bad))
    assert result.returncode == 1, result.stdout + result.stderr
    assert "step 11 of 28 does not stand" in result.stdout  # 9 footings, Column A1, then the beam
    line = next(line for line in result.stdout.splitlines() if "Beam A1-A2" in line and "moved" in line)
    moved_m = float(line.split(" moved ")[1].split(" m ")[0])
    assert moved_m > 0.5  # it tipped off and fell
    assert f"set down on Column A1 ({names['Column A1']})" in line
    assert f"it rests on Column A2 ({names['Column A2']}), not placed before it" in line
    assert "steps 12–28 were not checked" in result.stdout  # the replay stopped there, and says so
    assert f"to try: place Column A2 ({names['Column A2']}) earlier" in result.stdout
    assert "bimbot.services.physics" not in result.stdout + result.stderr  # the verdict says it, with names


def test_a_column_before_its_footing_drops_into_the_open_pit(bundled_build: Path, tmp_path: Path) -> None:
    manifest = read_manifest(bundled_build)
    names = {c.name: c.guid for c in manifest.components}
    depth = -next(c for c in manifest.components if c.name == "Footing B2").bbox_world.min_m[2]
    bad = _reordered(bundled_build, manifest, tmp_path, "Column B2", after=None)
    result = _check(bundled_build, "--sequence", str(bad))
    assert result.returncode == 1 and "step 1 of 28 does not stand" in result.stdout
    line = next(line for line in result.stdout.splitlines() if "Column B2" in line and "moved" in line)
    assert float(line.split(" moved ")[1].split(" m ")[0]) == pytest.approx(depth, abs=0.05)
    assert f"over the open pit of Footing B2 ({names['Footing B2']}), not placed yet" in line


def test_a_missing_sequence_file_is_one_line_and_exit_2(bundled_build: Path, tmp_path: Path) -> None:
    result = _check(bundled_build, "--sequence", str(tmp_path / "nope.xml"))
    assert result.returncode == 2 and "nope.xml: no such file" in result.stderr
    assert "Traceback" not in result.stderr


def test_the_advice_fits_the_order_checked() -> None:
    """In the support graph's own order (derived), reordering cannot help: a member that falls although all
    it rests on came first had nothing built beside it to be connected to, and the advice says so instead
    of "--derive"."""
    from bimbot.services.physics.stability import Moved, StabilityReport, StabilityStep, describe

    beam = Moved("b", "Beam", 3.5, placed_on=("c1",), rests_on=("c1", "c2"))
    step = StabilityStep(24, "b", "Beam", 2.0, 3.5, ("c1",), moved=(beam,))
    report = StabilityReport(85, [step], 24.0, 0.4)
    names = {"b": "Beam", "c1": "Column 1", "c2": "Column 2"}
    derived = describe(report, names, derived=True)
    assert "steps 25–85 were not checked" in derived[-2]
    assert "no component built beside it" in derived[-1] and "--derive" not in derived[-1]
    assert "--derive" in describe(report, names)[-1]  # a user's own order: try the support graph's
    unconnected = describe(report, names, derived=True, connections=False)[-1]
    assert "--no-connections" in unconnected and "is connected to it" in unconnected
    assert (
        "set down on Column 1 (c1) and came to rest on Column 2 (c2), still touching what it was set down on"
        in derived[1]
    )
    slid = Moved("b", "Beam", 0.2, placed_on=("c1", "c2"), rests_on=("c2", "c1"))
    assert (
        "set down on Column 1 (c1), Column 2 (c2) and came to rest still touching what it was set down on"
        in describe(
            StabilityReport(
                85, [StabilityStep(24, "b", "Beam", 2.0, 3.5, ("c1", "c2"), moved=(slid,))], 24.0, 0.4
            ),
            names,
        )[1]
    )
    # the derived order itself set a slab over a foundation's open pit (the Revit hub's step 1): reordering
    # by hand helps, "--derive" (already the order checked) does not
    slab = Moved("s", "Slab", 0.4, placed_on=(), rests_on=(), open_pits=("f",))
    over_pit = StabilityReport(115, [StabilityStep(1, "s", "Slab", 0.5, 0.5, (), moved=(slab,))], 1.0, 0.1)
    advice = describe(over_pit, {**names, "s": "Slab", "f": "Footing"}, derived=True)[-1]
    assert advice.startswith("to try: place Footing (f) earlier (--sequence F.xml)")
    assert "--derive" not in advice and "does not see open pits" in advice
    # the model itself puts it into what was placed before it: the advice is the model, not the order
    clash = Moved("b", "Beam", 0.23, placed_on=("c1",), rests_on=("c1",), clashes=(("c1", 0.229),))
    lines = describe(
        StabilityReport(85, [StabilityStep(24, "b", "Beam", 2.0, 0.23, ("c1",), moved=(clash,))], 24.0, 0.4),
        names,
        derived=True,
    )
    assert "the model puts it into Column 1 (c1) (229 mm deep): a clash in the IFC" in lines[1]
    assert lines[-1].startswith("to try: repair the clash in the model") and "--derive" not in lines[-1]
    assert "bimbot convert MODEL.ifc -o OUT/ --exclude b " in lines[-1]  # a command the user can paste
    fell = Moved("b", "Beam", 2.0, placed_on=("c1",), rests_on=())
    assert (
        "set down on Column 1 (c1) and came to rest on the ground"
        in describe(
            StabilityReport(
                85, [StabilityStep(24, "b", "Beam", 2.0, 3.5, ("c1",), moved=(fell,))], 24.0, 0.4
            ),
            names,
        )[1]
    )
