"""A finished run written as a real run writes it, without running the services.

Every component of the build's sequence is picked, carried, placed, verified and constructed in order,
ten sim seconds each, by robots r1 and r2 in turn; the last one fails (misplaced three times). The
agents' journal is written with the agents' own records (:class:`JournalRecord`) and the report by the
observer's :class:`ReportCollector`, so the exporters read exactly what they read after a real run.
"""

from __future__ import annotations

import json
from pathlib import Path

from bimbot.services.component_agents.journal import JournalRecord
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState, ComponentStateMsg, RobotState, RobotStateMsg
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.report.collector import ReportCollector, RunEnding

S = ComponentState
RUN_NAME = "20270301-070000"  # the run's start: 2027-03-01 07:00
STEP_S = 10.0  # sim seconds per component
# state entered, offset in the component's slot (s)
LIFT = (
    (S.PICKING, 0.0),
    (S.TRANSPORTING, 3.0),
    (S.ASSEMBLING, 6.0),
    (S.VERIFYING, 8.0),
    (S.CONSTRUCTED, 9.0),
)
ROBOT_TYPES = {"r1": "husky", "r2": "carrier"}


def _change(
    guid: str, state: S, previous: S, t: float, robot: str | None, **extra: object
) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid=guid,
        state=state,
        previous=previous,
        event="test",
        attempt=int(extra.pop("attempt", 1)),  # type: ignore[call-overload]
        robot_id=robot,
        sim_time_s=t,
        wall_time_s=1000.0 + t,
        **extra,  # type: ignore[arg-type]
    )


def frame_run_messages(order: list[str]) -> list[ComponentStateMsg]:
    """Every component's transitions, in time order (see the module)."""
    messages: list[ComponentStateMsg] = []
    for index, guid in enumerate(order):
        start, robot = index * STEP_S, ("r1", "r2")[index % 2]
        messages.append(_change(guid, S.RELEASED, S.PLANNED, start, None, attempt=0))
        previous = S.RELEASED
        if index == len(order) - 1:  # the last: placed off target, then failed
            for state, offset in LIFT[:4]:
                messages.append(_change(guid, state, previous, start + offset, robot))
                previous = state
            reason = Reason(code=ReasonCode.MISPLACED, message="placed 52 mm off its target three times")
            messages.append(_change(guid, S.FAILED, previous, start + 9.0, robot, reason=reason, attempt=3))
            continue
        for state, offset in LIFT:
            messages.append(_change(guid, state, previous, start + offset, robot))
            previous = state
    return messages


def write_run(build: Path, manifest: Manifest, order: list[str]) -> Path:
    """``build/runs/<RUN_NAME>/`` with the journal and report of :func:`frame_run_messages`."""
    run = build / "runs" / RUN_NAME
    (run / "state").mkdir(parents=True)
    (run / "report").mkdir()
    messages = frame_run_messages(order)
    with (run / "state" / "agents-1of1.jsonl").open("w", encoding="utf-8") as journal:
        for message in messages:
            journal.write(JournalRecord.from_message(message, None, None).model_dump_json() + "\n")
    collector = ReportCollector(manifest, order)
    for robot in ROBOT_TYPES:
        collector.add(
            RobotStateMsg(
                robot_id=robot,
                state=RobotState.IDLE,
                pose_xy_yaw=(0.0, 0.0, 0.0),
                sim_time_s=0.0,
                wall_time_s=1000.0,
            )
        )
    for message in messages:
        collector.add(message)
    report = collector.report(RunEnding("done", None, "the test's run ended"))
    for robot_id, robot_type in ROBOT_TYPES.items():
        report["robots"][robot_id]["type"] = robot_type  # what physics' site info says on a real run
    report["settings"] = {"sequence": "the build's sequence.xml"}
    (run / "report" / "report.json").write_text(json.dumps(report), encoding="utf-8")
    (build / "runs" / "latest").symlink_to(RUN_NAME)
    return run
