"""Panelisation benchmark: the Revit sample house converted with its walls and slabs panelised against the
plain conversion, in the same run (target: ratio ≤ 1.5).

Both are ``open + convert_model`` in this process, each into a folder of its own, run back to back in pairs
that alternate which goes first, so load from other processes weighs on both alike; the ratio is the median
of the pairs' ratios. Panelised: every IfcWall and IfcSlab is decided ``panelised`` (the default decision
panelises only what the limits ask for; forcing all of them is the heavier case). A wall that already fits
stays one panel, a slab always becomes planks 1.2–2.4 m wide.

Run: ``.venv/bin/python bench/panelise.py [--runs N]``.
"""

from __future__ import annotations

import argparse
import itertools
import resource
import statistics
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.shared.construction_methods import ConstructionMethod, MethodDecision, MethodSource
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Manifest

HOUSE = Path(__file__).resolve().parents[2] / "shared" / "samples" / "ifc" / "revit2021_sample_project.ifc"
TARGET_RATIO = 1.5
PANELISED_CLASSES = ("IfcWall", "IfcSlab")


def cpu_s() -> float:
    """CPU seconds of this process and of its ended children (the conversion's forked workers)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def convert(
    path: Path, out: Path, decisions: Mapping[str, MethodDecision]
) -> tuple[tuple[float, float], Manifest]:
    """((wall s, CPU s), manifest) of one conversion."""
    started, started_cpu = time.perf_counter(), cpu_s()
    manifest = convert_model(open_model(path), path, out, ConvertOptions(decisions=decisions))
    return (time.perf_counter() - started, cpu_s() - started_cpu), manifest


def forced_decisions(path: Path) -> dict[str, MethodDecision]:
    model = open_model(path)
    decision = MethodDecision(
        method=ConstructionMethod.PANELISED, source=MethodSource.USER, note="every wall and slab (benchmark)"
    )
    return {str(e.GlobalId): decision for cls in PANELISED_CLASSES for e in model.by_type(cls)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7, help="pairs of conversions (default 7)")
    parser.add_argument("--model", type=Path, default=HOUSE, help="IFC model (default: the Revit house)")
    args = parser.parse_args()
    decisions = forced_decisions(args.model)
    plain_s: list[tuple[float, float]] = []
    panel_s: list[tuple[float, float]] = []
    with tempfile.TemporaryDirectory() as tmp:
        fresh = itertools.count()

        def new_out() -> Path:
            return Path(tmp) / f"out{next(fresh)}"

        convert(args.model, new_out(), {})  # warm-up: imports, caches, file system
        _, manifest = convert(args.model, new_out(), decisions)
        for run in range(args.runs):
            order = ((plain_s, {}), (panel_s, decisions))
            for times, given in order if run % 2 == 0 else order[::-1]:
                times.append(convert(args.model, new_out(), given)[0])
    ratio = statistics.median(p[0] / q[0] for p, q in zip(panel_s, plain_s, strict=True))
    cpu_ratio = statistics.median(p[1] / q[1] for p, q in zip(panel_s, plain_s, strict=True))
    panels = sum(len(entry.panel_guids) for entry in manifest.panelised)
    print(f"{args.model.name}: {len(decisions)} walls and slabs decided panelised, {panels} panels written")
    for entry in manifest.panelised:
        masses = [c.mass_kg for c in manifest.components if c.parent_guid == entry.guid]
        print(
            f"  {entry.ifc_class} {entry.name!r}: {entry.mass_kg:,.0f} kg → {len(masses)} panel(s), "
            f"{min(masses):,.0f}–{max(masses):,.0f} kg"
        )
    for label, times in (("plain conversion    ", plain_s), ("panelised conversion", panel_s)):
        wall_ms = statistics.median(t[0] for t in times) * 1000
        cpu_ms = statistics.median(t[1] for t in times) * 1000
        print(f"  {label}  median {wall_ms:8.1f} ms wall, {cpu_ms:8.1f} ms CPU  ({args.runs} runs)")
    print(
        f"  ratio {ratio:.2f} wall, {cpu_ratio:.2f} CPU (medians of the pairs' ratios; "
        f"target ≤ {TARGET_RATIO})"
    )


if __name__ == "__main__":
    main()
