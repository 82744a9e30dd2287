"""``bimbot convert MODEL.ifc -o OUT/``: the command-line adapter of the converter.

What is built: building elements and their parts (:mod:`.selection`); ``--include``/``--exclude``/``--only``
change that by class. How each is built (lifted, panelised, cast in place, laid, with its host, in place):
what the IFC says, then the ``--methods`` file or preset (default ``prefab``), against the ``--fleet``'s
largest lift (:mod:`.method_decisions`). The summary line counts the components by method and the elements
left out by reason. ``--formats`` chooses the
visual mesh files (:mod:`.mesh_files` says which reader uses which); collision meshes are always written.

Exit codes: 0 when at least one component was converted, 1 when the model was read but nothing could be
converted (the manifest still lists why), 2 for unreadable input (one clear line, no traceback).
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import re
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Never

from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.output_paths import check_writable_dir
from bimbot.shared.reasons import CLASH_ADVICE

from .summary_line import clash_summary, elements_summary, framed_summary, methods_summary, skipped_summary

if TYPE_CHECKING:
    import ifcopenshell
    from tqdm import tqdm  # imported at run time only once a bar is shown (in update)

    from bimbot.shared.methods_file import MethodsFile

_log = logging.getLogger(__name__)
MAX_WARNINGS_SHOWN = 10  # the converter's warnings on stderr; every one is in the manifest
# warnings that change what a component weighs or where it stands come first on stderr: a guessed density
# moves the method and the robot a part gets; a note on how its geometry was decomposed changes neither
CHANGES_THE_BUILD = re.compile(r"density|weigh|\bmass\b|\bkg\b|clash|implausible", re.I)
MAX_JOINTS_LOGGED = 20  # joints logged one a line at INFO (the rest at DEBUG); every one is in the manifest
MAX_CLASHES_NAMED = 3  # clashes named in the warning; every one is in the manifest


def warnings_to_show(warnings: list[str], limit: int = MAX_WARNINGS_SHOWN) -> list[str]:
    """The first ``limit`` warnings, those that change the build (:data:`CHANGES_THE_BUILD`) first, each
    group in the manifest's order."""
    ranked = sorted(range(len(warnings)), key=lambda i: (CHANGES_THE_BUILD.search(warnings[i]) is None, i))
    return [warnings[i] for i in ranked[:limit]]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from .convert import ConvertOptions  # the run imports it anyway; the defaults are its fields

    parser.add_argument("model", type=Path, help="IFC file (IFC2X3, IFC4 or IFC4X3, STEP .ifc)")
    parser.add_argument("-o", "--output", type=Path, required=True, help="output folder (created if missing)")
    parser.add_argument(
        "--include",
        default="",
        help="also build these IFC classes, e.g. IfcFurnishingElement (comma-separated, with subclasses); "
        "by default building elements and their parts are built",
    )
    parser.add_argument(
        "--exclude",
        default="",
        help="leave out these IFC classes (comma-separated, with subclasses) or single elements by GlobalId",
    )
    parser.add_argument(
        "--in-place",
        default="",
        help="components in place before the robots come (cast in situ, built by others): 'foundations' "
        "(every component whose target lies in the ground), IFC classes or GlobalIds, comma-separated. "
        "They are converted, stand at their BIM pose from the start, and are neither built nor counted; "
        "what rests on them is built at once",
    )
    parser.add_argument(
        "--methods",
        default=None,
        metavar="FILE|PRESET",
        help="how each component is built: a methods file (bimbot methods show > methods.toml) or a preset, "
        "prefab, conventional or lifted (the paper's: everything lifted whole); default: what the IFC says, "
        "then prefab",
    )
    parser.add_argument(
        "--fleet",
        type=Path,
        default=None,
        metavar="FLEET.toml",
        help="the fleet that will build it: what is heavier than its largest lift is panelised or cast "
        "(default: bimbot's fleet)",
    )
    parser.add_argument(
        "--only",
        default="",
        help="build only these IFC classes instead of the building elements (comma-separated, subclasses)",
    )
    parser.add_argument(
        "--threads",
        type=int,
        default=None,
        help="worker processes, each tessellating and writing its share of the elements (default: all cores)",
    )
    parser.add_argument(
        "--formats",
        default=",".join(ConvertOptions.formats),
        help="visual mesh files to write, comma-separated: dae (Gazebo, named by model.sdf), obj (physics "
        "--gui), glb (the rerun observer; it falls back to obj); 'none' for collision meshes only "
        f"(default: {','.join(ConvertOptions.formats)})",
    )
    parser.add_argument(
        "--no-split-ifc",
        action="store_true",
        help="do not write each component's standalone <GUID>.ifc (the paper's component package has it; "
        "nothing in a run reads it); the Revit hub's 85 steel members convert in 0.75 s instead of 0.90 s",
    )
    parser.add_argument(
        "--joints",
        type=Path,
        default=None,
        help="joint rules (TOML): which overlaps the model draws are joints, by pair of classes and depth "
        "(default: bimbot's own, shared/joint_rules.toml, which says why each depth)",
    )
    parser.add_argument(
        "--build-context",
        action="store_true",
        help="build the context massing too: detached blocks of walls and slabs at least two storeys tall "
        "with no door, window or stair, drawn round a project that has them (neighbouring buildings); "
        "left out by default, each with its reason in manifest.json",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar even on a terminal")


def run(args: argparse.Namespace) -> int:
    from bimbot.shared.ifc_input import read_model
    from bimbot.shared.joints import load_joint_settings

    from .convert import ConversionStats, ConvertOptions, convert_model
    from .in_place import FOUNDATIONS, above_ground, named_existing
    from .mesh_files import parse_formats
    from .selection import check_classes, check_exclusions, check_in_place, parse_class_list

    started = time.perf_counter()
    if args.threads is not None and args.threads < 1:
        raise UserError("--threads must be at least 1")
    try:
        formats = () if args.formats.strip().lower() == "none" else parse_formats(args.formats)
    except ValueError as error:
        raise UserError(f"--formats: {error}") from None
    joints = load_joint_settings(args.joints)  # a bad file is one line before the model is read
    check_writable_dir(args.output, "--output")  # before the model is read: that may take minutes
    from bimbot.shared.fleet import load_fleet
    from bimbot.shared.methods_file import load_methods

    methods = load_methods(args.methods)
    fleet = load_fleet(args.fleet)
    model, damage = (read := read_model(args.model)).model, read.damage
    for warning in methods_warnings(model, methods):
        _log.warning("%s", warning)
    try:
        include = check_classes(model, parse_class_list(args.include))
        exclude, exclude_guids = check_exclusions(model, parse_class_list(args.exclude))
        only = check_classes(model, parse_class_list(args.only))
        foundations, in_place_guids, in_place_warnings = check_in_place(
            model, parse_class_list(args.in_place), FOUNDATIONS
        )
    except ValueError as error:
        raise UserError(str(error)) from None
    for warning in in_place_warnings:
        _log.warning("%s", warning)
    for guid in sorted(set(in_place_guids) & set(exclude_guids)):
        _log.warning("%s is in --exclude and --in-place: it is left out (--exclude wins)", guid)
    options = ConvertOptions(
        include=include,
        exclude=exclude,
        exclude_guids=exclude_guids,
        only=only,
        threads=args.threads,
        formats=formats,
        split_ifc=not args.no_split_ifc,
        in_place_guids=in_place_guids,
        foundations_in_place=foundations,
        joints=joints,
        methods=methods,
        fleet=fleet,
        build_context=args.build_context,
    )
    stats = ConversionStats()
    with _ProgressBar(
        enabled=not args.no_progress and sys.stderr.isatty(), lines=not args.no_progress
    ) as bar:
        try:
            manifest = convert_model(
                model, args.model, args.output, options, progress=bar.update, stats=stats, damage=damage
            )
        except OSError as error:
            if not _under(error.filename, args.output):
                raise  # not the output: a bug, with its traceback
            raise UserError(
                f"--output {args.output}: cannot write {error.filename} ({error.strerror})"
            ) from None
    seconds = time.perf_counter() - started
    _log.debug("stage seconds: %s", {k: round(v, 3) for k, v in stats.seconds_by_stage.items()})
    from .selection import left_out_by_selection

    for item in manifest.skipped:  # the selection's choices in the summary line; problems one line each
        level = logging.DEBUG if left_out_by_selection(item.reason) else logging.INFO
        _log.log(
            level, "skipped %s %s (%s): %s", item.ifc_class, item.guid, item.name or "unnamed", item.reason
        )
    for warning in warnings_to_show(manifest.warnings):
        _log.warning("%s", warning)
    if len(manifest.warnings) > MAX_WARNINGS_SHOWN:
        _log.warning(
            "… and %d more warning(s): 'warnings' in %s/manifest.json",
            len(manifest.warnings) - MAX_WARNINGS_SHOWN,
            args.output,
        )
    report_joints(manifest, args.output)
    origin = sequence_origin(manifest.sequence_source)
    sys.stdout.write(
        f"converted {len(manifest.components):,} component(s){elements_summary(manifest)}, "
        f"skipped {len(manifest.skipped):,}{skipped_summary(manifest.skipped)}, "
        f"{len(manifest.joints):,} joint(s){framed_summary(manifest)}, {clash_summary(manifest)}, "
        f"{len(manifest.warnings):,} warning(s) in {seconds:.1f} s → {args.output}/ "
        f"(world {manifest.world_file}, sequence {manifest.sequence_file} {origin})"
        f"{methods_summary(manifest)}\n"
    )
    from bimbot.shared.run_folder import run_folders

    earlier = len(run_folders(args.output))  # runs of what was converted here before
    if earlier:
        _log.warning(
            "%s/runs/ holds %d run(s) of an earlier conversion into this folder: their reports describe what "
            "was converted then (bimbot runs %s lists them; a new run gets a folder of its own)",
            args.output,
            earlier,
            args.output,
        )
    existing = named_existing(manifest.components)
    if existing:
        _log.warning(
            "%d component(s) to build are named existing (%s%s): if they stand before the build, convert "
            "with --in-place %s",
            len(existing),
            ", ".join(c.name or c.guid for c in existing[:3]),
            " …" if len(existing) > 3 else "",
            ",".join(c.parent_guid or c.guid for c in existing[:3]),
        )
    if manifest.in_place:  # what the user asked for (--in-place), said with the summary
        sys.stdout.write(
            "in place before the robots come: "
            + ", ".join(c.name or c.guid for c in manifest.in_place[:6])
            + (f" and {len(manifest.in_place) - 6} more" if len(manifest.in_place) > 6 else "")
            + "\n"
        )
    standing = above_ground(manifest.in_place)
    if standing:
        named = ", ".join(c.name or c.guid for c in standing[:3]) + (" …" if len(standing) > 3 else "")
        sys.stdout.write(
            f"{len(standing)} component(s) in place reach above the ground ({named}): physics, the robots' "
            "maps and the planner's access check have them where the model puts them\n"
        )
    if not manifest.components and manifest.in_place:
        _log.error(
            "%s: every component converted is in place (--in-place): nothing is left to build", args.model
        )
        return 1
    if not manifest.components:  # unusable input (exit 2): nothing in it can be built (the manifest says why)
        raise UserError(
            f"{args.model}: no element could be converted (see 'skipped' in {args.output}/manifest.json)"
        )
    return 0


def report_joints(manifest: Manifest, output: Path) -> None:
    """A line per joint at INFO (the first ``MAX_JOINTS_LOGGED``; every one is in the manifest) and one
    warning naming the deepest clashes, with the advice."""
    names = {c.guid: _named(c) for c in [*manifest.components, *manifest.in_place]}
    for index, joint in enumerate(manifest.joints):
        _log.log(
            logging.INFO if index < MAX_JOINTS_LOGGED else logging.DEBUG,
            "joint: %s set into %s, %.0f mm deep (%s: %s)",
            names.get(joint.guids[1], joint.guids[1]),
            names.get(joint.guids[0], joint.guids[0]),
            1000.0 * joint.depth_m,
            joint.source.value,
            joint.rule,
        )
    if len(manifest.joints) > MAX_JOINTS_LOGGED:
        more = len(manifest.joints) - MAX_JOINTS_LOGGED
        _log.info("… and %d more joint(s): 'joints' in %s/manifest.json", more, output)
    existing = {component.guid for component in manifest.in_place}
    # a clash between two parts in place touches no placement: they stand fixed where the model puts them
    built = [clash for clash in manifest.clashes if not set(clash.guids) <= existing]
    both_in_place = len(manifest.clashes) - len(built)
    in_place_words = (
        f" ({both_in_place} more between two parts in place, which stand fixed where the model puts them: "
        "no robot places them)"
        if both_in_place
        else ""
    )
    if built:
        shown = "; ".join(
            f"{names.get(a, a)} and {names.get(b, b)}, {1000.0 * clash.depth_m:.0f} mm"
            for clash in built[:MAX_CLASHES_NAMED]
            for a, b in [clash.guids]
        )
        more = len(built) - MAX_CLASHES_NAMED
        _log.warning(
            "the model puts %d pair(s) of components to build into each other, or into a part in place, with "
            "no joint between them (clashes in the IFC; physics pushes each pair apart): %s%s. To try: %s "
            "(--exclude GUID), or a joint rule (--joints FILE) where the overlap is a joint%s",
            len(built),
            shown,
            f"; and {more} more in {output}/manifest.json ('clashes')" if more > 0 else "",
            CLASH_ADVICE,
            in_place_words,
        )
    elif both_in_place:
        _log.info("no clash touches a component to build%s", in_place_words)


def _named(component: Component) -> str:
    return f"{component.ifc_class} {component.name or ''} ({component.guid})".replace("  ", " ")


def _under(filename: object, folder: Path) -> bool:
    """Whether an OSError's ``filename`` lies in the output ``folder`` (what the user chose)."""
    if not isinstance(filename, str | bytes | Path):
        return False
    path = Path(os.fsdecode(filename)).absolute()
    return path.is_relative_to(Path(folder).absolute())


def methods_warnings(model: ifcopenshell.file, methods: MethodsFile) -> list[str]:
    """The methods file's overrides that name nothing in ``model``: a GlobalId it lacks, a class its
    schema does not know."""
    from .selection import check_classes

    where = methods.source or "methods file"
    warnings = []
    for guid in methods.by_guid:
        try:
            model.by_guid(guid)
        except RuntimeError:
            warnings.append(f"{where}: by_guid {guid!r}: no element of the model has that GlobalId")
    for name in methods.by_class:
        try:
            check_classes(model, [name])
        except ValueError:
            warnings.append(f"{where}: by_class {name}: not a class of {model.schema}; it applies to nothing")
    return warnings


PROGRESS_LINE_S = 30.0  # off a terminal: a progress line at each stage's start, then at most this often


class _ProgressBar:
    """A tqdm bar per stage on a terminal; off one (a log, CI), a plain line at each stage's start and
    then every :data:`PROGRESS_LINE_S` of wall time, so a long conversion is seen to go on (a 2,365-product
    office converts in 5 min); none with ``--no-progress``."""

    def __init__(
        self, *, enabled: bool, lines: bool = False, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self._enabled = enabled
        self._lines = lines and not enabled
        self._clock = clock
        self._last_line_s = -math.inf
        self._bar: tqdm[Never] | None = None  # a bar without an iterable, updated by hand
        self._stage: str | None = None

    def __enter__(self) -> _ProgressBar:
        return self

    def __exit__(self, *_: object) -> None:
        if self._bar is not None:
            self._bar.close()

    def update(self, stage: str, done: int, total: int) -> None:
        if self._lines:
            now_s = self._clock()
            if stage != self._stage or now_s - self._last_line_s >= PROGRESS_LINE_S:
                starts = stage != self._stage
                self._stage, self._last_line_s = stage, now_s
                what = "" if stage == "convert" else f" ({stage})"
                line = (  # a start is not "0 of N done": a short conversion prints nothing after it
                    f"{total:,} IFC elements to convert{what}"
                    if starts
                    else f"{done:,} of {total:,} IFC elements converted{what}"
                )
                sys.stderr.write(f"bimbot convert: {line}\n")
            return
        if not self._enabled:
            return
        from tqdm import tqdm

        if stage != self._stage:
            if self._bar is not None:
                self._bar.close()
            self._bar = tqdm(total=total, desc=stage, unit="el", leave=False, file=sys.stderr)
            self._stage = stage
        assert self._bar is not None
        self._bar.n = done
        self._bar.refresh()


SEQUENCE_ORIGINS = {
    "ifc_schedule": "from the IFC's own schedule",
    "derived": "derived from the structure (what rests on what)",
    "ifc_schedule+derived": "from the IFC's schedule, the rest derived from the structure",
}


def sequence_origin(source: str) -> str:
    """Where the build's sequence came from, in words (``derived`` → "derived from the structure …")."""
    return SEQUENCE_ORIGINS.get(source, f"from {source}")
