"""Placements that can miss and structures that can fall, over the bus (issue 11).

``bimbot run`` with real processes on a loopback Zenoh bus builds generated light steel frames:

* a schedule that sets a beam on a single column: the beam is released onto the column, tips off, and its
  agent judges it ``unstable`` after every attempt (its drift named), while the rest of the frame is built
  (or, when the fallen beam boxes the robot in, not built with that reason);
* a schedule that sets a column before its footing: the column drops into the footing's open pit;
* a robot type with a poor hand (its precision in the fleet file): its placements miss, the agents catch
  every miss with its numbers and the retries fix them; every error comes from physics, none is injected.
  In the plan fidelity: physics draws a placement's error from the type's precision and settles the part
  as in the physics fidelity (``services/physics/placing.py``); how the carrier drives there is not the
  subject (``test_full_build.py`` catches a misplacement in the physics fidelity).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fleets import ground_fleet_file
from frames import convert_small_frame
from wall_clock import bound_s

from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import read_manifest, write_manifest
from bimbot.shared.run_folder import latest_run_folder
from bimbot.shared.sequence import sequence_from_predecessors, write_sequence

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 400


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bimbot.cli", *args],
        capture_output=True,
        text=True,
        timeout=bound_s(RUN_TIMEOUT_S),
        check=False,
    )


@pytest.fixture(scope="module")
def two_by_one(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return convert_small_frame(tmp_path_factory.mktemp("frame_2x1"), (2, 1))


def _copy(build: Path, tmp_path: Path) -> Path:
    out = tmp_path / "build"
    shutil.copytree(build, out)
    return out


def _chain(build: Path, names: list[str], tmp_path: Path) -> Path:
    """A user's schedule: these components in this order, each after the one before."""
    guid = {c.name: c.guid for c in read_manifest(build).components}
    order = [guid[name] for name in names]
    chain = {g: {order[i - 1]} for i, g in enumerate(order) if i}
    return write_sequence(sequence_from_predecessors(order, chain, source="user"), tmp_path / "schedule.xml")


def _report(build: Path) -> dict:
    return json.loads((latest_run_folder(build).report_dir / "report.json").read_text())


def _by_name(report: dict) -> dict[str, dict]:
    return {component["name"]: component for component in report["components"]}


def test_a_beam_set_on_a_single_column_tips_off_is_unstable_and_the_rest_goes_on(
    two_by_one: Path, tmp_path: Path
) -> None:
    """In a build that gives the beam no temporary support (the converter props it while it is unconnected:
    tests/run/test_check_stability.py), one bolted end is a hinge and the beam tips off its column."""
    build = _copy(two_by_one, tmp_path)
    manifest = read_manifest(build)
    bare = [c.model_copy(update={"temporary_support": None}) for c in manifest.components]
    write_manifest(manifest.model_copy(update={"components": bare}), build)
    schedule = _chain(build, ["Footing A1", "Footing A2", "Column A1", "Beam A1-A2", "Column A2"], tmp_path)
    fleet = str(ground_fleet_file(tmp_path))  # one carrier
    result = _bimbot("run", str(build), "--fleet", fleet, "--sequence", str(schedule), "-q")
    assert result.returncode == 1, result.stdout + result.stderr[-2000:]
    components = _by_name(_report(build))
    beam = components["Beam A1-A2"]
    assert beam["state"] == "failed" and beam["reason"]["code"] == "unstable"
    assert "moved" in beam["reason"]["message"] and beam["max_drift_mm"] > 100.0  # it fell
    assert "--check-stability" in beam["reason"]["message"]  # and what a user can do about it
    assert [p["cause"] for p in beam["placements"]] == ["unstable"] * 3
    assert all(components[name]["state"] == "constructed" for name in ("Footing A1", "Footing A2"))
    # Column A2 comes after the beam: the failed beam does not hold it up, it is released and tried. Where
    # the beam comes to rest after its third fall is physics': now and then it boxed in the robot that had
    # just released it (no_progress), or lay across Column A2's footing, so that the column was set down on
    # it (unstable, then 10.5 mm off: misplaced). Then the column is not built either, and says why.
    column = components["Column A2"]
    assert column["released_s"] is not None and column["released_s"] >= beam["failed_s"], column
    if column["state"] != "constructed":
        assert column["state"] == "failed", column
        assert column["reason"]["code"] in {"no_progress", "robot_trapped", "unstable", "misplaced"}, column
        assert column["reason"]["message"], column
    assert "unstable" in result.stdout and "Beam A1-A2" in result.stdout  # the closing table names it


def test_a_column_set_before_its_footing_drops_into_the_open_pit(two_by_one: Path, tmp_path: Path) -> None:
    build = _copy(two_by_one, tmp_path)
    schedule = _chain(build, ["Footing A2", "Column A1", "Footing A1", "Column A2", "Beam A1-A2"], tmp_path)
    fleet = str(ground_fleet_file(tmp_path))  # one carrier
    result = _bimbot(
        "run", str(build), "--fleet", fleet, "--sequence", str(schedule), "--max-attempts", "1", "-q"
    )
    assert result.returncode == 1, result.stdout + result.stderr[-2000:]
    column = _by_name(_report(build))["Column A1"]
    assert column["state"] == "failed" and column["reason"]["code"] == "unstable"
    message = column["reason"]["message"]
    moved_m = float(message.split("moved ")[1].split(" m ")[0])
    assert "open pit" in message and 0.2 < moved_m < 0.6  # down to the pit's floor, 0.3 m (it may lean)


def test_a_robot_type_with_a_poor_hand_misses_the_agents_catch_it_and_the_retries_fix_it(
    tmp_path: Path,
) -> None:
    build = convert_small_frame(tmp_path / "frame_2x2", (2, 2))
    fleet_file = tmp_path / "poor_hands.toml"
    fleet = default_fleet()
    carrier = fleet.types["carrier"]
    fleet_file.write_text(
        "\n".join(
            [
                'default_type = "carrier"',
                "[types.carrier]",
                *(f"{name} = {json.dumps(value)}" for name, value in _toml_fields(carrier)),
                "placement_precision_m = 0.006  # a poor hand: 6 mm, 1 sigma per axis",
                "[[robots]]",
                'type = "carrier"',
                "count = 1",
            ]
        )
        + "\n"
    )
    result = _bimbot(
        "run", str(build), "--fleet", str(fleet_file), "--derive", "--max-attempts", "8",
        "--fidelity", "plan", "-q",
    )  # fmt: skip
    report = _report(build)
    assert result.returncode == 0, result.stdout + result.stderr[-2000:]
    misses = [
        placement
        for component in report["components"]
        for placement in component["placements"]
        if placement["verdict"] == "misplaced"
    ]
    assert misses, "a 6 mm hand misses the 10 mm tolerance about once in four placements"
    assert all(miss["cause"] == "misplaced" and miss["position_error_mm"] > 10.0 for miss in misses)
    assert report["totals"]["retries_by_cause"]["misplaced"] == len(misses) == report["totals"]["retries"]
    assert all(component["state"] == "constructed" for component in report["components"])
    assert report["totals"]["max_position_error_mm"] <= 10.0  # every component within tolerance at the end
    by_type = report["totals"]["placement_error_mm_by_type"]["carrier"]
    assert by_type["out_of_tolerance"] == len(misses) and by_type["max"] > 10.0


def _toml_fields(description) -> list[tuple[str, object]]:  # type: ignore[no-untyped-def]
    """The carrier's description as TOML lines, all but its precision (set by the test)."""
    data = description.model_dump(mode="json", exclude={"placement_precision_m", "crane", "name"})
    return [(name, value) for name, value in data.items() if value is not None]
