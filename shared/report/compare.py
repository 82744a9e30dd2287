"""Two runs side by side, by construction method: what each method built and what its work took.

Why: a builder choosing between ways to build (``--methods prefab`` against ``--methods conventional``,
or two fleets) asks where the time goes. Each run's ``report.json`` lists its components with their
method and when each step happened (:mod:`.methods`); this sums them per method:

* ``components`` and ``constructed``;
* ``work_s``: the time the work itself took, summed over what was built: a lift from pick to placement
  (``lifted``, ``panelised``), formwork and pour (``cast_in_place``: from ``forming_s`` to ``placed_s``),
  laying (``laid``: from ``laying_s``), pitching and driving (``driven``: from ``driving_s``); a part
  installed with its host (``with_host``) has none of its own;
* ``cure_s``: the longest cure of its components (concrete that must cure before what rests on it);
* ``span_s``: from the first start of that method's work to its last component built.

Two runs compare only when they built the same model (one model converted two ways is one building) at
the same fidelity: :func:`mismatches` says each run that does not, which ``bimbot compare`` warns of and
marks in its table.

Pure: report dicts in, rows out (``bimbot compare`` prints them).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from .building_name import building_name, model_file

WORK_START = {  # the report field where a method's own work starts (placed_s ends it)
    "lifted": "picked_s",
    "panelised": "picked_s",
    "cast_in_place": "forming_s",
    "laid": "laying_s",
    "driven": "driving_s",
}


@dataclass(frozen=True)
class MethodFigures:
    """One method's figures in one run."""

    components: int = 0
    constructed: int = 0
    work_s: float = 0.0
    cure_s: float = 0.0
    span_s: float = 0.0


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) else None


def by_method(report: Mapping[str, Any]) -> dict[str, MethodFigures]:
    """Method → its figures in ``report`` (a parsed ``report.json``)."""
    grouped: dict[str, list[Mapping[str, Any]]] = {}
    for component in report.get("components") or ():
        grouped.setdefault(str(component.get("method") or "lifted"), []).append(component)
    figures: dict[str, MethodFigures] = {}
    for method, components in sorted(grouped.items()):
        built = [c for c in components if c.get("state") == "constructed"]
        work_s, starts, ends, cures = 0.0, [], [], [0.0]
        for component in built:
            start = _number(component.get(WORK_START.get(method, ""), None))
            end = _number(component.get("placed_s")) or _number(component.get("constructed_s"))
            if start is not None and end is not None and end >= start:
                work_s += end - start
                starts.append(start)
            if end is not None:
                ends.append(end)
            curing = component.get("curing") or {}
            cure_from, cure_until = _number(curing.get("from_s")), _number(curing.get("until_s"))
            if cure_from is not None and cure_until is not None:
                cures.append(cure_until - cure_from)
        span_s = max(ends) - min(starts) if starts and ends else 0.0
        figures[method] = MethodFigures(len(components), len(built), work_s, max(cures), span_s)
    return figures


@dataclass(frozen=True)
class TypeFigures:
    """One robot type's figures in a run: how many robots, the components they built, their busy time and
    the distance they drove (a new user found compare silent on what each robot did)."""

    robots: int
    built: int
    busy_s: float
    distance_m: float


@dataclass(frozen=True)
class RunColumn:
    """A run as ``bimbot compare`` shows it: a label, what it built (``building``: its site and model, by
    name; ``model_sha256`` tells two models apart) at which fidelity, its makespan and its figures by
    method."""

    label: str
    makespan_s: float | None
    constructed: int
    components: int
    methods: dict[str, MethodFigures]
    site: str | None = None
    model: str | None = None  # the IFC file's name
    model_sha256: str | None = None
    fidelity: str | None = None  # None: a report that does not say
    fleet: str | None = None  # what robots built it (:func:`fleet_of`); None: a report that does not say
    seed: int | None = None
    ending: str | None = (
        None  # how the run ended (``done``, ``interrupted``, …); None: a report that does not say
    )
    retries: int = 0  # placements caught off target or unstable and tried again
    give_backs: int = 0
    walled_in_s: dict[str, float] = field(default_factory=dict)  # robot id → sim s it stood walled in
    by_type: dict[str, TypeFigures] = field(default_factory=dict)  # robot type → its robots' figures

    @property
    def ended_early(self) -> bool:
        """Stopped before its end (interrupted, timed out, stalled): its figures cover part of the build."""
        return self.ending not in (None, "done", "running")

    @property
    def building(self) -> str:
        """``greenhouse-site (light_steel_frame.ifc)``; the model alone where the site has no name of its
        own (Revit names every site "Default": a trial user read "default" as the building); ``unknown``
        for a report that names neither."""
        return building_name(self.site, self.model)


def run_column(label: str, report: Mapping[str, Any]) -> RunColumn:
    totals = report.get("totals") or {}
    settings = report.get("settings") or {}
    model = settings.get("model") or {}
    return RunColumn(
        label=label,
        makespan_s=_number(totals.get("makespan_s")),
        constructed=int(totals.get("constructed") or 0),
        components=int(totals.get("components") or 0),
        methods=by_method(report),
        site=report.get("site"),
        model=model_file(report),
        model_sha256=model.get("sha256"),
        fidelity=settings.get("fidelity"),
        fleet=fleet_of(settings, report.get("robots")),
        seed=settings.get("seed"),
        ending=(report.get("ending") or {}).get("how"),
        retries=int(totals.get("retries") or 0),
        give_backs=int(totals.get("give_backs") or 0),
        walled_in_s=_walled_in_s(report.get("robots") or {}, _number(totals.get("last_constructed_s"))),
        by_type=_by_type(report.get("robots") or {}),
    )


def _walled_in_s(robots: Mapping[str, Any], end_s: float | None) -> dict[str, float]:
    """Robot id → the sim seconds it stood walled in (a spell with no end: to ``end_s``)."""
    spells: dict[str, float] = {}
    for robot_id, figures in robots.items():
        for spell in figures.get("walled_in") or []:
            until = spell.get("until_s") if spell.get("until_s") is not None else end_s
            if until is not None:
                spells[robot_id] = spells.get(robot_id, 0.0) + max(
                    0.0, float(until) - float(spell["since_s"])
                )
    return spells


def _by_type(robots: Mapping[str, Any]) -> dict[str, TypeFigures]:
    """Robot type → :class:`TypeFigures`, summed over its robots."""
    types: dict[str, TypeFigures] = {}
    for figures in robots.values():
        kind = str(figures.get("type") or "unknown")
        old = types.get(kind, TypeFigures(0, 0, 0.0, 0.0))
        types[kind] = TypeFigures(
            old.robots + 1,
            old.built + int(figures.get("built") or 0),
            old.busy_s + float(figures.get("busy_s") or 0.0),
            old.distance_m + float(figures.get("distance_m") or 0.0),
        )
    return types


def fleet_of(settings: Mapping[str, Any], robots_seen: Mapping[str, Any] | None = None) -> str | None:
    """What robots a run had, from its report's settings: ``3 carrier(s) (--robots 3), with the fleet's
    machines``, or ``3 robot(s) of the default type, …`` when the report's robots do not name the type
    (a trial user asked which type that was); else its fleet (``the default fleet``, a fleet file's path);
    None when the report does not say. ``robots_seen``: the report's ``robots`` (robot id → its figures)."""
    robots, fleet = settings.get("robots"), settings.get("fleet")
    if robots:
        types = Counter(str(entry.get("type")) for entry in (robots_seen or {}).values() if entry.get("type"))
        named = [kind for kind, count in types.items() if count == robots]
        if len(named) == 1:
            return f"{robots} {named[0]}(s) (--robots {robots}), with the fleet's machines"
        return f"{robots} robot(s) of the default type, with the fleet's machines"
    return str(fleet) if fleet else None


def same_building(a: RunColumn, b: RunColumn) -> bool:
    """Whether two runs built the same model: the same site and, where both reports say it, the same
    model file (by content). One model converted two ways (``--methods``) is the same building."""
    if a.site != b.site:
        return False
    return a.model_sha256 is None or b.model_sha256 is None or a.model_sha256 == b.model_sha256


def same_fidelity(a: RunColumn, b: RunColumn) -> bool:
    """Whether two runs ran at the same fidelity (a report that does not say is taken to)."""
    return a.fidelity is None or b.fidelity is None or a.fidelity == b.fidelity


def mismatches(columns: Sequence[RunColumn]) -> list[str]:
    """One sentence per run that does not compare with the first: another building, another fidelity
    (a ``plan`` run's times come from kinematic robots, a ``physics`` run's from the simulation); and one
    per run that ended early (interrupted, timed out, stalled)."""
    first = columns[0]
    said = [
        f"{column.label} ended {column.ending} with {column.constructed}/{column.components} constructed: "
        "its figures cover only the part of the build it got to"
        for column in columns
        if column.ended_early
    ]
    for column in columns[1:]:
        if not same_building(first, column):
            said.append(
                f"{column.label} built {column.building}, {first.label} built {first.building}: different "
                "buildings, their figures do not compare"
            )
        if not same_fidelity(first, column):
            said.append(
                f"{column.label} ran at fidelity {column.fidelity}, {first.label} at {first.fidelity}: their "
                "times are not measured alike (plan: kinematic robots; physics: the simulation)"
            )
    return said


def methods_in(columns: Sequence[RunColumn]) -> list[str]:
    """Every method any of the runs used, in a stable order."""
    return sorted({method for column in columns for method in column.methods})
