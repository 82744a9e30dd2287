"""``bimbot run OUT/ --check-stability``: does every partial structure of the sequence stand?

A physics-only replay of the plan the planner would build by (the build's sequence, ``--sequence F.xml``
or ``--derive``), without robots (:mod:`bimbot.services.physics.stability`): seconds for a frame, so a user
can try a schedule before rehearsing it. It prints whether every partial structure stands or the first step
that does not (which component moved, how far, what it was set down on, what it rests on that was not
placed before it) and exits 0 when it stands, 1 when not, 2 for unusable input.
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Callable
from pathlib import Path

from bimbot.services.component_agents.agent import AgentConfig
from bimbot.services.physics.connections import ConnectionConfig
from bimbot.services.physics.stability import check_stability, describe
from bimbot.services.planner.sources import PlanSource, SourceKind, load_plan
from bimbot.shared.errors import UserError
from bimbot.shared.service_runner import resolve_build


def plan_source(args: argparse.Namespace) -> PlanSource:
    if args.derive:
        return PlanSource(SourceKind.DERIVE)
    if args.sequence is not None:
        if not Path(args.sequence).is_file():
            raise UserError(f"--sequence {args.sequence}: no such file")
        return PlanSource(SourceKind.SEQUENCE, Path(args.sequence))
    return PlanSource(SourceKind.BUILD)


def check_stability_command(args: argparse.Namespace, say: Callable[[str], None]) -> int:
    """Replay the plan's order in physics; print the verdict; 0 when every partial structure stands."""
    logging.getLogger("bimbot.services").setLevel(logging.WARNING)  # the verdict is the output
    # physics' own warning of a component that moved says, in GUIDs, what the verdict says with names
    logging.getLogger("bimbot.services.physics.watching").setLevel(logging.ERROR)
    build = resolve_build(args.build)
    plan = load_plan(build.manifest, build.dir, plan_source(args))
    steps = len(plan.order)
    say(f"checking the stability of the plan, {plan.source}: {steps} step(s), physics only, no robots")
    tolerance_m = AgentConfig().tolerances.drift_m  # what the agents of a run accept
    connections = ConnectionConfig(enabled=args.connections)
    if not connections.enabled:
        say("without connections: every component must stand by itself (--no-connections)")
    report = check_stability(
        build.manifest, build.dir, plan.order, drift_tolerance_m=tolerance_m, connections=connections
    )
    names = {c.guid: c.name or c.ifc_class for c in build.manifest.components}
    derived = args.derive or (args.sequence is None and build.manifest.sequence_source == "derived")
    for line in describe(report, names, derived=derived, connections=connections.enabled):
        say(line)
    return 0 if report.stands else 1
