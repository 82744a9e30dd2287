"""Converter benchmark: overhead against bare tessellation, and time per element as models grow.

Overhead (target ≤ 1.3): the full conversion against ifcopenshell's bare tessellation of the same elements
with the same settings and threads, in the same run. Cases: the bundled light steel frame, the largest
public sample (acad2010_objects.ifc), the Revit structural hub's steel (``--only IfcBeam,IfcColumn``: the
closest public model to issue 12's "64-member Revit steel model") and the whole hub. Measured two ways, each
as convert/bare pairs run back to back (alternating which goes first), the ratio the median of the pairs'
ratios, so that load from other processes weighs on both sides alike:

* in process — ``open + convert_model`` against ``open + iterate + read vertices/faces``;
* as commands — ``bimbot convert`` against a ``python -c`` that opens and tessellates (both pay
  interpreter start-up and imports, as a user does); then ``bimbot convert --no-split-ifc`` (no standalone
  IFC per component) the same way, and the floor: the bare command that also imports what
  ``bimbot convert`` imports, converting nothing (the ratio no conversion can go below).

Scaling: generated light steel frames of ~100, ~1,000 and ~10,000 elements, converted in process; time
per element must stay flat. Run: ``.venv/bin/python bench/convert.py [--quick]``.

Models at scale (``--model FILE.ifc``, ``--frame NxM``, repeatable): the target applies as it stands to a
model whose bare tessellation takes ≥ 10 s in the same run, where start-up does not weigh: in process,
``--runs`` convert/bare pairs (default 1), the imports and caches warmed on the bundled frame first, the
stages of the first conversion printed; below 10 s the line says the ratio is the small-model one (see
the floor above). The public restaurant sample is a zip whose compression Python's zipfile cannot read:
``unzip -d /tmp …/revit2012_janesville_restaurant.zip`` first.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.shape

from bimbot.data.light_steel_frame import build_light_steel_frame
from bimbot.demo import bundled_model_path
from bimbot.services.converter.convert import ConversionStats, ConvertOptions, convert_model
from bimbot.services.converter.selection import select_elements
from bimbot.services.converter.tessellation import default_threads, geometry_settings
from bimbot.shared.ifc_input import open_model

SAMPLES = Path(__file__).resolve().parents[2] / "shared" / "samples" / "ifc"
HUB = SAMPLES / "revit2021_structural_hub.ifc"
HUB_STEEL = ("IfcBeam", "IfcColumn")
TARGET_RATIO = 1.3
BARE_SCRIPT = """
import sys, ifcopenshell, ifcopenshell.geom, ifcopenshell.util.shape
sys.path.insert(0, {root!r})
from bimbot.services.converter.selection import select_elements
from bimbot.services.converter.tessellation import default_threads, geometry_settings
model = ifcopenshell.open({path!r})
elements = list(select_elements(model, only={only!r}).elements)
iterator = ifcopenshell.geom.iterator(geometry_settings(), model, default_threads(), include=elements)
if iterator.initialize():
    while True:
        shape = iterator.get()
        ifcopenshell.util.shape.get_vertices(shape.geometry)
        ifcopenshell.util.shape.get_faces(shape.geometry)
        if not iterator.next():
            break
"""

# What a `bimbot convert` command imports before it converts anything (the CLI, the converter, the manifest)
CONVERTER_IMPORTS = "import bimbot.cli, bimbot.services.converter.cli, bimbot.services.converter.convert\n"


@dataclass(frozen=True)
class Case:
    label: str
    path: Path
    only: tuple[str, ...] = ()  # --only classes; empty: the default selection


def bare_tessellation(path: Path, only: Sequence[str] = ()) -> int:
    model = ifcopenshell.open(str(path))
    elements = list(select_elements(model, only=only).elements)
    iterator = ifcopenshell.geom.iterator(geometry_settings(), model, default_threads(), include=elements)
    count = 0
    if iterator.initialize():
        while True:
            shape = iterator.get()
            ifcopenshell.util.shape.get_vertices(shape.geometry)
            ifcopenshell.util.shape.get_faces(shape.geometry)
            count += 1
            if not iterator.next():
                break
    return count


def full_conversion(
    path: Path, out: Path, stats: ConversionStats | None = None, only: Sequence[str] = ()
) -> int:
    options = ConvertOptions(only=tuple(only))
    return len(convert_model(open_model(path), path, out, options, stats=stats).components)


def seconds(action: Callable[[], object]) -> float:
    started = time.perf_counter()
    action()
    return time.perf_counter() - started


@dataclass(frozen=True)
class Paired:
    """Convert and bare timings taken in alternation, so load from other processes hits both alike."""

    convert_s: list[float]
    bare_s: list[float]

    @property
    def ratio(self) -> float:
        """Median of the per-pair ratios (each pair ran back to back)."""
        return statistics.median(c / b for c, b in zip(self.convert_s, self.bare_s, strict=True))

    def line(self, label: str) -> str:
        convert_ms, bare_ms = statistics.median(self.convert_s) * 1000, statistics.median(self.bare_s) * 1000
        best = min(self.convert_s) / min(self.bare_s)
        return (
            f"  {label}: convert {convert_ms:8.1f} ms   bare tessellation {bare_ms:8.1f} ms   "
            f"ratio {self.ratio:5.2f} (fastest runs {best:4.2f}; target ≤ {TARGET_RATIO})"
        )


def paired(convert: Callable[[], object], bare: Callable[[], object], runs: int) -> Paired:
    convert_s, bare_s = [], []
    for run in range(runs):
        first, second = (convert, bare) if run % 2 == 0 else (bare, convert)  # alternate who goes first
        a, b = seconds(first), seconds(second)
        convert_s.append(a if first is convert else b)
        bare_s.append(b if first is convert else a)
    return Paired(convert_s, bare_s)


def overhead(case: Case, runs: int) -> None:
    path, only = case.path, case.only
    with tempfile.TemporaryDirectory() as tmp:
        # every conversion into a folder of its own, as a first conversion: re-converting into the same
        # folder also deletes the earlier output (a thousand files), which no bare tessellation does
        fresh = itertools.count()

        def new_out() -> Path:
            return Path(tmp) / f"out{next(fresh)}"

        full_conversion(path, new_out(), only=only)  # warm-up (imports, numba/trimesh caches, file system)
        bare_tessellation(path, only)
        stats = ConversionStats()
        full_conversion(path, new_out(), stats, only)
        in_process = paired(
            lambda: full_conversion(path, new_out(), only=only), lambda: bare_tessellation(path, only), runs
        )

        def convert_command(*extra: str) -> list[str]:
            return [
                sys.executable,
                "-m",
                "bimbot.cli",
                "-q",
                "convert",
                str(path),
                "-o",
                str(new_out()),
                "--no-progress",
                *(["--only", ",".join(only)] if only else []),
                *extra,
            ]

        root = str(Path(__file__).resolve().parents[1])
        bare_command = [sys.executable, "-c", BARE_SCRIPT.format(root=root, path=str(path), only=only)]

        def against_bare(command: Callable[[], list[str]]) -> Paired:
            """``command()`` (made anew each run) and the bare command, run as processes in pairs."""
            return paired(
                lambda: subprocess.run(command(), check=True, capture_output=True),
                lambda: subprocess.run(bare_command, check=True, capture_output=True),
                runs,
            )

        as_commands = against_bare(convert_command)
        without_split = against_bare(lambda: convert_command("--no-split-ifc"))
        # the bare command that also imports what `bimbot convert` imports: the ratio's floor as commands
        floor_command = [
            sys.executable,
            "-c",
            CONVERTER_IMPORTS + BARE_SCRIPT.format(root=root, path=str(path), only=only),
        ]
        imports_only = against_bare(lambda: floor_command)
    n = bare_tessellation(path, only)
    print(f"{case.label} ({path.name}{', --only ' + ','.join(only) if only else ''}): {n} elements")
    stages = ", ".join(f"{name} {seconds * 1000:.0f} ms" for name, seconds in stats.seconds_by_stage.items())
    print(f"  stages of one conversion: {stages}")
    whole_s = stats.seconds_by_stage.get("select", 0.0) + stats.seconds_by_stage.get("shards_wall", 0.0)
    whole_s += stats.seconds_by_stage.get("joints", 0.0) + stats.seconds_by_stage.get(
        "world_sequence_manifest", 0.0
    )
    joints_s = stats.seconds_by_stage.get("joints", 0.0)
    print(
        f"  joints and clashes: {joints_s * 1000:.0f} ms, "
        f"{joints_s / max(whole_s, 1e-9):.2f} of the conversion"
    )
    print(in_process.line("in process "))
    print(as_commands.line("as commands"))
    print(without_split.line("as commands, --no-split-ifc"))
    print(
        f"  floor as commands (the bare command plus the converter's imports, no conversion): "
        f"ratio {imports_only.ratio:4.2f}"
    )


def scaling(sizes: list[tuple[int, int]]) -> None:
    print("scaling (generated light steel frames, in process):")
    per_element: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        for columns_x, columns_y in sizes:
            source = Path(tmp) / f"frame_{columns_x}x{columns_y}.ifc"
            build_light_steel_frame(columns_x, columns_y).write(str(source))
            stats = ConversionStats()
            started = time.perf_counter()
            count = full_conversion(source, Path(tmp) / f"out_{columns_x}x{columns_y}", stats)
            seconds = time.perf_counter() - started
            per_element.append(seconds / count)
            stages = ", ".join(f"{name} {value:.1f}s" for name, value in stats.seconds_by_stage.items())
            print(
                f"  {columns_x}x{columns_y}: {count:6d} elements  {seconds:7.2f} s  "
                f"{seconds / count * 1000:6.2f} ms/element  ({stages})"
            )
    print(f"  time per element, largest / smallest: {per_element[-1] / per_element[0]:.2f} (flat ≈ 1)")


LARGE_BARE_S = 10.0  # a model whose bare tessellation takes this long: start-up does not weigh


def at_scale(label: str, path: Path, runs: int) -> None:
    """Convert/bare pairs in process on one large model; the ratio, its bare time and the stages."""
    with tempfile.TemporaryDirectory() as tmp:
        fresh = itertools.count()
        bundled = bundled_model_path()
        full_conversion(bundled, Path(tmp) / "warm-up")  # imports, numba and trimesh caches: not the model's
        bare_tessellation(bundled)
        stats = ConversionStats()

        def convert() -> int:
            number = next(fresh)
            return full_conversion(path, Path(tmp) / f"out{number}", stats if number == 0 else None)

        counts: list[int] = []
        pairs = paired(convert, lambda: counts.append(bare_tessellation(path)), runs)
    bare_s = statistics.median(pairs.bare_s)
    n = counts[0]
    print(f"{label} ({path.name}): {n} elements, bare tessellation {bare_s:.1f} s (same run)")
    stages = ", ".join(f"{name} {seconds:.1f} s" for name, seconds in stats.seconds_by_stage.items())
    print(f"  stages of the first conversion: {stages}")
    print(pairs.line("in process "))
    if bare_s < LARGE_BARE_S:
        print(f"  bare tessellation under {LARGE_BARE_S:g} s: start-up weighs; compare with the floor")


def scale_cases(models: list[str], frames: list[str], tmp: Path) -> list[tuple[str, Path]]:
    """(label, IFC path) of each ``--model`` and each generated ``--frame`` (written into ``tmp``)."""
    found: list[tuple[str, Path]] = [("model", Path(model)) for model in models]
    for frame in frames:
        columns_x, columns_y = (int(part) for part in frame.lower().split("x"))
        path = tmp / f"frame_{columns_x}x{columns_y}.ifc"
        build_light_steel_frame(columns_x, columns_y).write(str(path))
        found.append((f"generated frame {columns_x}x{columns_y}", path))
    return found


def file_creation_ms(parent: str, folders: int = 50) -> float:
    """Milliseconds per entry to make ``folders`` folders of four small files each under ``parent``."""
    with tempfile.TemporaryDirectory(dir=parent) as tmp:
        started = time.perf_counter()
        for index in range(folders):
            folder = Path(tmp) / f"m{index}" / "meshes"
            folder.mkdir(parents=True)
            for name in ("a", "b", "c", "d"):
                (folder / name).write_bytes(b"x" * 4096)
        return (time.perf_counter() - started) / (folders * 5) * 1000


def cases() -> list[Case]:
    """The bundled frame, the largest public sample, the hub's steel and the whole hub (where present)."""
    found = [Case("bundled frame", bundled_model_path())]
    if SAMPLES.is_dir():
        largest = max(SAMPLES.glob("*.ifc"), key=lambda p: p.stat().st_size)
        found.append(Case("largest sample", largest))
    if HUB.is_file():
        found += [Case("hub steel", HUB, HUB_STEEL), Case("whole hub", HUB)]
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer runs, scaling only to ~1,000 elements")
    parser.add_argument("--case", action="append", help="cases whose label contains this (repeatable)")
    parser.add_argument("--no-scaling", action="store_true", help="overhead only")
    parser.add_argument("--model", action="append", default=[], help="a large IFC model to measure")
    parser.add_argument("--frame", action="append", default=[], help="a generated frame NxM to measure")
    parser.add_argument("--runs", type=int, default=1, help="convert/bare pairs per large model (1)")
    args = parser.parse_args()
    if args.model or args.frame:
        with tempfile.TemporaryDirectory() as tmp:
            for label, path in scale_cases(args.model, args.frame, Path(tmp)):
                at_scale(label, path, args.runs)
        return
    runs = 5 if args.quick else 9
    where = tempfile.gettempdir()
    print(
        f"conversions write under {where} (TMPDIR): {file_creation_ms(where):.3f} ms to create a file there "
        "(on one VM, 0.03 to 0.9 ms by folder and hour: a converter writes ten files an element)"
    )
    for case in cases():
        if not args.case or any(part in case.label for part in args.case):
            overhead(case, runs)
    if args.no_scaling:
        return
    sizes = [(6, 6), (18, 18)] if args.quick else [(6, 6), (18, 18), (58, 58)]
    scaling(sizes)


if __name__ == "__main__":
    main()
