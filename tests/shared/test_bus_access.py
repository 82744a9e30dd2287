"""The secured bus's rules come from the message registry: every topic's publisher may put on it and nobody
else may, only a queryable's answerer may answer, robots speak only under their own id, and Zenoh accepts
the block as its ``access_control`` config."""

from __future__ import annotations

import json
import re

import pytest
import zenoh

from bimbot.shared.bus_access import (
    ANY_SITE,
    ROUTER_USER,
    BusUser,
    access_control,
    bus_users,
    key_expr,
    may_put,
    robot_user,
    speakers_of,
)
from bimbot.shared.keyspace import Queryable, Topic
from bimbot.shared.messages import CLOCK, KEY_SPACE, PHYSICS_SKIP, ROBOT_CMD_VEL, TOPICS, TwinMsg

SITE = "site_a"
ROBOTS = ("r1", "r2")


def _example_key(template: str, robot_id: str = "r1") -> str:
    """A concrete key of ``template`` on SITE (robot parts ``robot_id``, other parts ``k1``)."""
    parts = {"site": SITE, "robot_id": robot_id}
    return re.sub(r"\{(\w+)\}", lambda m: parts.get(m.group(1), "k1"), template)


def _speaks(user: BusUser, topic: Topic) -> bool:
    return user.speaker is not None and user.speaker in speakers_of(topic)


@pytest.fixture(scope="module")
def acl() -> dict:
    return access_control(ROBOTS, SITE)


def test_every_topic_publisher_of_the_registry_may_put_on_its_topic(acl: dict) -> None:
    for topic in TOPICS.values():
        publishers = [user for user in bus_users(ROBOTS) if _speaks(user, topic)]
        assert publishers, f"nobody may publish {topic.template}"
        for user in publishers:
            key = _example_key(topic.template, user.robot_id or "r1")
            assert may_put(acl, user.name, key), f"{user.name} may not put on {key}"


def test_nobody_but_a_topics_publisher_may_put_on_it(acl: dict) -> None:
    for topic in TOPICS.values():
        key = _example_key(topic.template)
        for user in bus_users(ROBOTS):
            if not _speaks(user, topic):
                assert not may_put(acl, user.name, key), f"{user.name} may put on {key}"


def test_a_robot_puts_only_under_its_own_id_and_never_the_clock(acl: dict) -> None:
    assert may_put(acl, robot_user("r2"), ROBOT_CMD_VEL.key(site=SITE, robot_id="r2"))
    assert not may_put(acl, robot_user("r2"), ROBOT_CMD_VEL.key(site=SITE, robot_id="r1"))
    assert not may_put(acl, robot_user("r2"), CLOCK.key(site=SITE))
    assert may_put(acl, "physics", CLOCK.key(site=SITE))


def test_observer_and_monitor_may_put_nowhere_and_rules_stay_on_the_site(acl: dict) -> None:
    for topic in TOPICS.values():
        for user in ("observer", "monitor"):
            assert not may_put(acl, user, _example_key(topic.template))
    assert not may_put(acl, "physics", "bimbot/other_site/clock")
    keys = {key for rule in acl["rules"] for key in rule["key_exprs"]}
    assert all(key.startswith(f"bimbot/{SITE}/") for key in keys), keys


def _rule_keys(acl: dict, user: str, message: str) -> set[str]:
    allowed = {rule for policy in acl["policies"] if user in policy["subjects"] for rule in policy["rules"]}
    return {
        key
        for rule in acl["rules"]
        if rule["id"] in allowed and message in rule["messages"] and rule["flows"] == ["ingress"]
        for key in rule["key_exprs"]
    }


def test_only_the_answerer_declares_a_queryable_and_only_robots_send_requests(acl: dict) -> None:
    queryables = [entry for entry in KEY_SPACE if isinstance(entry, Queryable)]
    for user in bus_users(ROBOTS):
        declared = _rule_keys(acl, user.name, "declare_queryable")
        mine = {key_expr(q.template, SITE) for q in queryables if q.answerer == user.speaker}
        assert declared == mine, user.name
        asked = _rule_keys(acl, user.name, "query")
        reads = {key_expr(q.template, SITE) for q in queryables if q.request is None}
        requests = {key_expr(q.template, SITE) for q in queryables if q.request is not None}
        assert reads <= asked, f"{user.name} cannot read the twins, site info or plan"
        assert (requests <= asked) == (user.speaker == "robot"), user.name


def test_the_planner_may_ask_physics_to_skip_its_clock_and_send_no_other_request(acl: dict) -> None:
    requests = {key_expr(q.template, SITE) for q in KEY_SPACE if isinstance(q, Queryable) and q.request}
    asked = _rule_keys(acl, "planner", "query") & requests
    assert asked == {key_expr(PHYSICS_SKIP.template, SITE)}
    assert key_expr(PHYSICS_SKIP.template, SITE) not in _rule_keys(acl, "observer", "query")


def test_liveliness_tokens_only_under_the_users_own_kind(acl: dict) -> None:
    assert _rule_keys(acl, robot_user("r1"), "liveliness_token") == {f"bimbot/{SITE}/alive/robot/r1"}
    assert _rule_keys(acl, "agents", "liveliness_token") == {f"bimbot/{SITE}/alive/component/*"}
    assert _rule_keys(acl, "observer", "liveliness_token") == {f"bimbot/{SITE}/alive/observer/*"}


def test_the_router_user_routes_everything_and_default_is_deny(acl: dict) -> None:
    assert acl["enabled"] is True and acl["default_permission"] == "deny"
    assert may_put(acl, ROUTER_USER, CLOCK.key(site=SITE))
    subjects = {name for subject in acl["subjects"] for name in subject["usernames"]}
    assert subjects == {ROUTER_USER, *(user.name for user in bus_users(ROBOTS))}


def test_zenoh_accepts_the_block_as_its_access_control_config() -> None:
    config = zenoh.Config()
    config.insert_json5("access_control", json.dumps(access_control(ROBOTS)))
    assert json.loads(config.get_json("access_control/default_permission")) == "deny"
    assert access_control(ROBOTS)["rules"][0]["key_exprs"] == [f"bimbot/{ANY_SITE}/**"]


def test_an_unknown_speaker_a_bad_robot_id_or_site_is_refused() -> None:
    stranger = Topic("bimbot/{site}/x", TwinMsg, "crane", "all")
    with pytest.raises(ValueError, match="crane"):
        access_control(ROBOTS, SITE, (*KEY_SPACE, stranger))
    with pytest.raises(ValueError, match="robot id"):
        access_control(("r/1",), SITE)
    with pytest.raises(ValueError, match="must differ"):
        access_control(("r1", "r1"), SITE)
    with pytest.raises(ValueError, match="site"):
        access_control(ROBOTS, "a/b")
