"""The plan fidelity's navigator stands in for the full one (``context.navigator``): every method it
defines takes the arguments the full navigator's does, so a caller written against the full one (the
parking's quiet retry) cannot crash a plan-fidelity robot."""

from __future__ import annotations

import inspect

from bimbot.services.robot.navigator import Navigator
from bimbot.services.robot.plan_executor import PlanNavigator


def test_every_method_the_plan_navigator_shares_with_the_navigator_takes_the_same_parameters() -> None:
    shared = [
        name
        for name, member in vars(PlanNavigator).items()
        if callable(member) and not name.startswith("_") and callable(getattr(Navigator, name, None))
    ]
    assert "set_goal" in shared and "cancel" in shared
    for name in shared:
        full = inspect.signature(getattr(Navigator, name)).parameters
        plan = inspect.signature(getattr(PlanNavigator, name)).parameters
        assert list(plan) == list(full), name
        for parameter, spec in full.items():
            assert plan[parameter].kind == spec.kind, (name, parameter)
