"""The planner tells how far its preparation is while it checks the plan's access (the restaurant's check
took minutes on a loaded machine, and the run took the silent planner for a hung one)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from planner_builders import one_robot_site_info
from site_models import ROOM_WALLS

from bimbot.services.planner.access_plan import access_plan
from bimbot.services.planner.preparing import PreparationReporter
from bimbot.services.planner.sources import Plan, PlanSource, SourceKind, load_plan
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import PreparingMsg
from bimbot.shared.site_access import SiteAccess, check_order
from bimbot.shared.support_graph import support_predecessors


def _walls_first_derived(build: Path) -> tuple[Manifest, Plan]:
    """The walls-first build's order with support precedences only (derived): the walls cut the column
    off, and the access plan may mend it."""
    manifest = read_manifest(build)
    given = load_plan(manifest, build, PlanSource(SourceKind.BUILD))
    support = support_predecessors(manifest.components)
    predecessors = {g: frozenset(support[g]) for g in given.order}
    return manifest, replace(given, predecessors=predecessors, derived=True)


def test_the_access_check_reports_each_step_of_each_round(walls_first_build: Path) -> None:
    manifest, plan = _walls_first_derived(walls_first_build)
    heard: list[tuple[str, int, int]] = []
    outcome = access_plan(
        plan,
        manifest,
        one_robot_site_info(manifest),
        adjust=True,
        report=lambda stage, done, total: heard.append((stage, done, total)),
    )
    quiet = access_plan(plan, manifest, one_robot_site_info(manifest), adjust=True)
    assert (
        outcome.plan.order == quiet.plan.order and outcome.added == quiet.added >= 1
    )  # reports change nothing
    steps = len(plan.order)
    assert heard[0] == ("access check: the site grid", 0, len(manifest.components))
    grid = [done for stage, done, _ in heard if stage == "access check: the site grid"]
    assert grid == list(range(len(manifest.components)))  # the grid's own progress (40 s at 9,802)
    first = [done for stage, done, total in heard if stage == "access check" and total == steps]
    assert first == list(range(steps))  # every placement of the first check
    assert any(stage == "access check, mended 1 time(s)" for stage, _, _ in heard)


def test_reports_go_out_when_the_stage_changes_and_at_most_every_few_seconds_within_one() -> None:
    now = [0.0]
    sent: list[PreparingMsg] = []
    report = PreparationReporter(sent.append, every_s=2.0, clock=lambda: now[0])
    for step in range(10):  # 10 steps in 0.9 s: one report
        now[0] = step * 0.1
        report("access check", step, 10)
    assert [(m.stage, m.done) for m in sent] == [("access check", 0)]
    now[0] = 1.0
    report("access check, mended 1 time(s)", 0, 10)  # a new stage: at once
    now[0] = 2.9
    report("access check, mended 1 time(s)", 5, 10)  # within every_s: not sent
    now[0] = 3.0
    report("access check, mended 1 time(s)", 6, 10)
    assert [(m.stage, m.done) for m in sent][1:] == [
        ("access check, mended 1 time(s)", 0),
        ("access check, mended 1 time(s)", 6),
    ]


def test_a_reset_grid_checks_an_order_as_a_fresh_one_does(walls_first_build: Path) -> None:
    """The access plan checks each mended order on the same grid, reset, instead of building it again."""
    manifest, plan = _walls_first_derived(walls_first_build)
    info = one_robot_site_info(manifest)
    robot = info.robot_types["default"]
    access = SiteAccess(manifest.components, info.layout, robot)
    fresh_region = access.region().copy()
    first = check_order(access, plan.order)
    assert first.cut_offs  # the walls cut the column off: the grid changed
    access.reset()
    assert not access.placed
    assert (access.region() == fresh_region).all()
    assert check_order(access, plan.order) == first
    names = {c.guid: c.name for c in manifest.components}
    assert {names[cut] for _, cut in first.cut_offs} == {"Column R1"}
    assert {names[placed] for placed, _ in first.cut_offs} <= set(ROOM_WALLS)
