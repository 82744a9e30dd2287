"""Connections as on site and temporary supports, over the bus: columns on base plates and anchor bolts over
cast pads (bolted bases), a beam framed between their tops (pinned ends), a precast wall panel on a strip
footing in place (grouted, on two props until its grout has set) and a plank bearing on the beam and the
panel (friction only). Real processes on a loopback bus, real pybullet; the clock skips the pads' cure.
The fleet is the default fleet's carrier, tower crane and concrete pump, the machines this site needs
(its Husky and block layer, idle here, would each be a process answering every lock-step step)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from connections_model import write_connections_model
from fleets import fleet_file
from wall_clock import bound_s

from bimbot.shared.methods_file import load_methods
from bimbot.shared.run_folder import RunFolder

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 300


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "bimbot.cli", *args]
    return subprocess.run(
        command, capture_output=True, text=True, timeout=bound_s(RUN_TIMEOUT_S), check=False
    )


def test_members_are_connected_as_on_site_and_the_panel_stands_on_props_until_its_grout_sets(
    tmp_path: Path,
) -> None:
    ifc, build = write_connections_model(tmp_path / "site.ifc"), tmp_path / "build"
    converted = _bimbot("convert", str(ifc), "-o", str(build), "--in-place", "foundations", "--no-progress")
    assert converted.returncode == 0, converted.stderr[-3000:]
    run = RunFolder(tmp_path / "run")
    fleet = fleet_file(tmp_path, {"carrier": 1, "tower_crane": 1, "concrete_pump": 1})
    result = _bimbot(
        "run", str(build), "--run-dir", str(run.root), "--fleet", str(fleet),
        "--timeout-s", f"{bound_s(RUN_TIMEOUT_S) - 60:.0f}",
    )  # fmt: skip
    detail = f"{result.stdout}\n{result.stderr[-3000:]}"
    assert result.returncode == 0, detail
    assert "constructed 7/7 components" in result.stdout, detail
    report = json.loads((run.report_dir / "report.json").read_text())
    by_name = {c["name"]: c for c in report["components"]}
    guid = {c["name"]: c["guid"] for c in report["components"]}
    assert by_name["Column 0"]["connections"] == {guid["Pad 0"]: "bolted_base"}
    assert by_name["Column 1"]["connections"] == {guid["Pad 1"]: "bolted_base"}
    assert by_name["Beam"]["connections"] == {guid["Column 0"]: "pinned_end", guid["Column 1"]: "pinned_end"}
    assert by_name["Plank"]["connections"] == {guid["Beam"]: "bearing", guid["Panel"]: "bearing"}
    assert list(by_name["Panel"]["connections"].values()) == ["grouted"]
    props = by_name["Panel"]["temporary_supports"]
    assert len(props) == 1 and props[0]["count"] == 2
    grout_set_s = load_methods().connections.grout_set_s
    assert props[0]["removed_s"] is not None and props[0]["stood_s"] >= grout_set_s  # off once the grout set
    for name in ("Column 0", "Column 1", "Beam", "Plank"):  # fixed or bearing at once: nothing propped
        assert by_name[name]["temporary_supports"] == []
    supports = report["totals"]["temporary_supports"]
    assert supports["used"] == 2 and supports["most_at_once"] == 2 and supports["standing_at_end"] == 0
    assert report["totals"]["connections_by_kind"] == {
        "bearing": 2,
        "bolted_base": 2,
        "grouted": 1,
        "pinned_end": 2,
    }
