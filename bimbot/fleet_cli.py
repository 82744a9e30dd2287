"""``bimbot fleet check OUT/ [--fleet FLEET.toml] [--robots N]``: what the fleet can build, without building.

Why: a builder choosing robots wants to know, before a run, which robot types can build each component of
the model, and why none can build the others (``too_heavy``, ``out_of_reach`` with the numbers). The table
comes from the planner's own feasibility check (:mod:`bimbot.services.planner.feasibility`) on the same
site plan physics would make, so a run fails exactly these components before it starts.
``bimbot fleet show`` prints bimbot's default fleet file, a starting point for one's own; with ``--fleet``
or ``--robots`` it prints the fleet a run would use (a file's types laid over the default's). Exit 0 when
the fleet can build every component, 1 when it cannot build some (the table says which and why), 2 for
unusable input.

Columns: ``built by / why not`` lists every route, the first being the one the planner's bids usually
take; a crane is named with its robot id because where it stands (the site plan sets it up where its hook
covers the building best, then the yard, :mod:`bimbot.shared.site_machines`) decides what it reaches;
``A → crane (r3, hand-off)`` is a ground robot of type A bringing the component within the crane's hook
first; a component cast in place, laid or driven (column ``method``, counted by method under the table) is
built where it stands by a machine that pours, lays or drives piles, named with its robot id when it stands
fixed (its boom must cover the whole footprint from where the site plan puts it).
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from bimbot.services.planner.capability import SiteRobot, robots_on_plan
from bimbot.services.planner.feasibility import SEE_ITS_ROWS, Feasibility, advice_tally, feasibility_table
from bimbot.shared.crane_count import crane_count_words, sized_cranes
from bimbot.shared.crane_erection import erected_for, erection_words
from bimbot.shared.fleet import DEFAULT_FLEET_FILE, Fleet, check_urdfs, load_fleet
from bimbot.shared.idle_machines import idle_machine_types, without_types
from bimbot.shared.manifest import Component, Joint, Manifest, require_components
from bimbot.shared.option_types import positive_int
from bimbot.shared.service_runner import resolve_build
from bimbot.shared.site_layout import plan_site
from bimbot.shared.site_plan import Rect
from bimbot.shared.support_graph import support_predecessors

if TYPE_CHECKING:
    from rich.table import Table

_log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("check", "show"), help="check: feasibility table; show: the fleet")
    parser.add_argument("build", type=Path, nargs="?", help="converted build folder (check)")
    parser.add_argument("--fleet", type=Path, default=None, metavar="FLEET.toml", help="default: bimbot's")
    parser.add_argument(
        "--robots",
        type=positive_int,
        default=None,
        help="N robots of the default type, plus the fleet's machines that stand fixed (cranes, pumps, …)",
    )
    parser.add_argument("--json", action="store_true", help="check: one JSON object per component")
    parser.add_argument(
        "--summary",
        action="store_true",
        help="check: the totals and the components that cannot be built, none of the rest; those of one "
        "class whose reasons say the same but for their figures take one row (a large build's full "
        "table runs to thousands of rows above its totals)",
    )


def fleet_in_force(fleet: Fleet, path: Path | None, robots: int | None) -> str:
    """The fleet a run would use, as a fleet file (TOML): the types a file changes laid over bimbot's own,
    ``--robots`` applied, a URDF of the file's own folder given by its full path (the text stands alone)."""
    import tomli_w

    data = fleet.model_dump(mode="json", exclude_none=True)
    for description in data["types"].values():
        urdf = Path(description["urdf"])
        if fleet.base_dir and not urdf.is_absolute() and (Path(fleet.base_dir) / urdf).is_file():
            description["urdf"] = str(Path(fleet.base_dir) / urdf)
    given = [f"{path} laid over bimbot's default fleet" if path is not None else "bimbot's default fleet"]
    if robots is not None:
        given.append(f"--robots {robots}")
    head = f"# the fleet in force: {', '.join(given)} ({fleet.summary()})\n"
    return head + tomli_w.dumps(data)


def checked(
    manifest: Manifest, fleet: Fleet
) -> tuple[list[tuple[Component, Feasibility]], list[SiteRobot], Rect]:
    """The feasibility table of a build for ``fleet``, on the site plan physics would make; the robots where
    that plan puts them; the building's rectangle."""
    components = list(manifest.components)
    descriptions = fleet.robot_types()
    layout = plan_site(components, fleet=descriptions)
    robots = robots_on_plan(list(fleet.type_of()), descriptions, layout)
    rows = feasibility_table(components, robots, dict(layout.slots))
    return list(zip(components, rows, strict=True)), robots, layout.building


def set_up_head(building: Rect) -> str:
    """``set up round the building (x 130.5–366.3, y 243.5–404.6 m; …):`` (a new user could not place the
    machines' coordinates without the building's own)."""
    (x0, y0), (x1, y1) = building.min_xy, building.max_xy
    return (
        f"set up round the building (x {x0:.1f}–{x1:.1f}, y {y0:.1f}–{y1:.1f} m, the site frame of "
        "manifest.json's targets; each machine at x, y):"
    )


def set_up_entries(robots: Sequence[SiteRobot]) -> list[str]:
    """``tower_crane r3 (248.4, 410.8)``…: where each machine that stands fixed stands, for the line after
    the totals (a new user could not tell where a second crane stood)."""
    entries = []
    for robot in robots:
        if robot.stands_fixed:
            x, y, _ = robot.home_xy_yaw
            more = len(robot.set_up_at) - 1
            extra = f" and {more} more set-up(s)" if more > 0 else ""
            entries.append(f"{robot.description.name} {robot.robot_id} ({x:.1f}, {y:.1f}){extra}")
    return entries


def run(args: argparse.Namespace) -> int:
    fleet = load_fleet(args.fleet)
    if args.robots is not None:
        fleet = fleet.with_robots(args.robots)
    if args.action == "show":
        if args.fleet is None and args.robots is None:  # bimbot's own file, with its comments
            sys.stdout.write(DEFAULT_FLEET_FILE.read_text(encoding="utf-8"))
        else:
            sys.stdout.write(fleet_in_force(fleet, args.fleet, args.robots))
        return 0
    if args.build is None:
        from bimbot.shared.errors import UserError

        raise UserError("bimbot fleet check: give the converted build folder (OUT/)")
    check_urdfs(fleet)  # as physics would: a missing model is one line here too
    manifest = resolve_build(args.build).manifest
    require_components(args.build, manifest)
    # the machines bimbot run leaves off site stay off here too, so the robots' ids are the run's
    idle = idle_machine_types(fleet, (component.method for component in manifest.components))
    fleet = without_types(fleet, idle)
    sized = sized_cranes(fleet, manifest.components)  # as bimbot run sizes the cranes for the footprint
    erected = erected_for(sized, manifest.components)  # as physics erects the cranes for the building
    raised, fleet = [*crane_count_words(fleet, sized), *erection_words(sized, erected)], erected
    rows, robots, building = checked(manifest, fleet)
    code = 0 if all(row.reason is None for _, row in rows) else 1  # 1: some component has no route
    if args.json:
        for component, row in rows:
            record = {
                "guid": row.guid,
                "name": component.name,
                "ifc_class": component.ifc_class,
                "method": component.method.value,
                "method_source": component.method_source.value,
                "mass_kg": round(component.mass_kg, 1),
                "target_top_m": round(component.bbox_world.max_m[2], 3),
                "routes": list(row.routes),
                "reason": row.reason.model_dump(mode="json") if row.reason else None,
            }
            sys.stdout.write(json.dumps(record) + "\n")
        return code
    if idle:
        sys.stdout.write(f"off site, no work in this build (as bimbot run leaves them): {', '.join(idle)}\n")
    sys.stdout.writelines(f"{words}\n" for words in raised)
    _print_table(rows, fleet, manifest.joints, only_unbuildable=args.summary)
    machines = set_up_entries(robots)
    if machines:
        sys.stdout.writelines(
            line + "\n" for line in packed_lines(set_up_head(building), machines, CONSOLE_WIDTH)
        )
    return code


CONSOLE_WIDTH = 160


def _print_table(
    rows: list[tuple[Component, Feasibility]],
    fleet: Fleet,
    joints: Sequence[Joint],
    *,
    only_unbuildable: bool = False,
) -> None:
    """The table (with ``only_unbuildable``: only the rows that cannot be built), then the totals."""
    from rich.console import Console
    from rich.table import Table

    source = f"the fleet of {fleet.source}: " if fleet.source != str(DEFAULT_FLEET_FILE) else ""
    shown = [(c, row) for c, row in rows if row.reason is not None] if only_unbuildable else rows
    what = "cannot build" if only_unbuildable else "can build"
    table = Table(title=f"what {source}{fleet.summary()} {what} ({len(shown)} of {len(rows)} components)")
    if only_unbuildable:
        _summary_rows(table, shown)
    else:
        for column in ("component", "class", "method", "mass kg", "top m", "built by / why not"):
            table.add_column(column, justify="right" if column in ("mass kg", "top m") else "left")
        for component, row in shown:
            how = "; ".join(row.routes) if row.reason is None else f"[red]{row.reason.line()}[/red]"
            table.add_row(
                f"{component.name or component.guid}",
                component.ifc_class,
                component.method.value,
                f"{component.mass_kg:,.0f}",
                f"{component.bbox_world.max_m[2]:.2f}",
                how,
            )
    console = Console(width=CONSOLE_WIDTH)
    if shown:
        console.print(table)
    failed = Counter(row.reason.code.value for _, row in rows if row.reason is not None)
    routes = Counter(route for _, row in rows for route in row.routes[:1])
    buildable = sum(1 for _, row in rows if row.reason is None)
    summary = ", ".join(f"{count} {code}" for code, count in failed.items()) or "none"
    blocked = resting_on_unbuildable(
        [component for component, _ in rows], {r.guid for _, r in rows if r.reason}, joints
    )
    methods = Counter(component.method.value for component, _ in rows)
    console.print("by method: " + ", ".join(f"{count} {method}" for method, count in methods.most_common()))
    console.print(f"buildable: {buildable} of {len(rows)}; cannot: {summary}")
    tally = advice_tally([row.reason for _, row in rows if row.reason is not None])
    if any(not label.endswith(SEE_ITS_ROWS) for label, _ in tally):  # else it only repeats "cannot:"
        entries = [f"{label}: {count}" for label, count in tally]
        for line in packed_lines(
            "what would build the rest, by the reasons' advice:", entries, CONSOLE_WIDTH
        ):
            console.print(line, soft_wrap=True)
    if blocked:
        console.print(
            f"of the buildable, {len(blocked)} rest (directly or through others) on one that cannot: a run "
            f"fails them blocked_by, so it can build at most {buildable - len(blocked)}"
        )
    if routes:
        head = (
            "first route (of each buildable component, the first machine that can do its work, as the "
            'full table\'s "built by" column names it; a run gives each task to the capable machine '
            "that bids best): "
        )
        entries = [f"{count} {route}" for route, count in routes.most_common()]
        for line in packed_lines(head, entries, CONSOLE_WIDTH):
            console.print(line, soft_wrap=True)


def _summary_rows(table: Table, shown: list[tuple[Component, Feasibility]]) -> None:
    """The rows of ``--summary``: components of one class whose reasons say the same but for their
    figures take one row (how many, each differing figure as its range, the first names), as in the run's
    not-built table; the most frequent reason first. The Revit office's 4,105 rows had run to 39,709 lines
    above the totals."""
    from bimbot.run.table import by_reason, same_reason_together

    plain = [
        (component.name or component.guid, component.guid, component.ifc_class, row.reason.code.value,
         row.reason.message)
        for component, row in shown
        if row.reason is not None
    ]  # fmt: skip
    counts = Counter(item[3] for item in plain)
    for column in ("component", "class", "why not"):
        table.add_column(column)
    for name, _, ifc_class, code, message in by_reason(same_reason_together(plain), counts):
        table.add_row(name, ifc_class, f"[red]{code}: {message}[/red]")


def packed_lines(head: str, entries: Sequence[str], width: int) -> list[str]:
    """``head`` and ``entries`` joined by ", " in lines of at most ``width`` characters, broken only between
    entries (the console broke "216 piling_rig (r6)" between its name and its id)."""
    lines, line = [], head.rstrip()
    for index, entry in enumerate(entries):
        piece = entry + ("," if index < len(entries) - 1 else "")
        joined = f"{line} {piece}" if line else piece
        if len(joined) > width and line.strip():
            lines.append(line)
            joined = piece
        line = joined
    lines.append(line)
    return lines


def resting_on_unbuildable(
    components: list[Component], unbuildable: set[str], joints: Sequence[Joint] = ()
) -> set[str]:
    """The GUIDs, not in ``unbuildable``, that rest on one of them in the support graph (the model's joints
    ordered as the converter orders them), transitively: what a run blocks (the planner's ``blocked_by``)
    when the model's own sequence is not given."""
    dependents: dict[str, set[str]] = {}
    for guid, supports in support_predecessors(components, joints=joints, cycles_level=logging.INFO).items():
        for support in supports:
            dependents.setdefault(support, set()).add(guid)
    blocked: set[str] = set()
    pending = list(unbuildable)
    while pending:
        for dependent in dependents.get(pending.pop(), ()):
            if dependent not in blocked and dependent not in unbuildable:
                blocked.add(dependent)
                pending.append(dependent)
    return blocked
