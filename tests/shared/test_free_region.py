"""The free region kept current round each change (shared/free_region.py): along random builds of the
bundled frame with a room and a gate in its doorway (a placement that closes the room splits the region,
lifting the gate joins it again), the region read after every placement and removal is the one a whole
labelling gives, cell for cell; most changes are decided in their window, the splits and joins on the
whole grid."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_site_access import _region_from_scratch, _room_with_gate

from bimbot.shared import free_region, site_access
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_access import AccessConfig, SiteAccess
from bimbot.shared.site_layout import plan_site


def test_the_region_kept_round_each_change_is_the_whole_labelling_s(
    bundled_build: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    built, column, ring, gate = _room_with_gate(bundled_build)
    layout = plan_site(built, robots=1)
    decided = {"window": 0, "whole": 0}

    def counted(*args: object) -> np.ndarray | None:
        answer = free_region.updated_region(*args)  # type: ignore[arg-type]
        decided["window" if answer is not None else "whole"] += 1
        return answer

    monkeypatch.setattr(site_access, "updated_region", counted)
    rng = np.random.default_rng(3)
    guids = [component.guid for component in built]
    closed = 0
    for _ in range(3):
        access = SiteAccess(built, layout, DEFAULT_ROBOT, AccessConfig(0.1))
        access.region()
        order = [str(guid) for guid in rng.permutation(guids)]
        for step, guid in enumerate(order):
            access.place(guid)
            if step % 4 == 3:
                access.remove(order[step - 1])  # back to its yard slot
            region = access.region()
            assert np.array_equal(region, _region_from_scratch(access)), (step, guid)
            closed += ring.guid in access.placed and gate.guid in access.placed
    assert closed, "some build closed the room with its gate"
    assert decided["window"] > decided["whole"] > 0
    assert column.guid in guids
