"""Who may speak on a secured bus: the router's Zenoh ``access_control`` block, derived from the registry.

The registry (:data:`bimbot.shared.messages.KEY_SPACE`) names who speaks on every key: a :class:`Topic`'s
``publisher`` ("physics", "planner/robot": the planner or a robot) and a :class:`Queryable`'s ``answerer``.
This module turns it into rules the router enforces on its links, one bus user per service role:

=============  ============  ==================================================================
bus user       speaks as     may also
=============  ============  ==================================================================
``physics``    physics       token ``alive/physics/*``
``planner``    planner       token ``alive/planner/*``; ask physics to skip a quiet site's clock
                             (``physics/skip``)
``agents``     agent         token ``alive/component/*`` (every shard and token session)
``robot-<id>`` robot         token ``alive/robot/<id>``; its topics under ``robots/<id>/`` only;
                             ask the queryables that take a request (physics attach/place/drop)
``observer``   nobody        token ``alive/observer/*``
``monitor``    nobody        token ``alive/monitor/*`` (``bimbot run``'s own session, ``bimbot watch``)
``bus``        everything    another bimbot router linking to this one
=============  ============  ==================================================================

Everyone may receive everything under ``bimbot/<site>/`` (every *egress* message), subscribe, watch
liveliness, and ask the queryables that take no request (twins, site info, poses, the plan): reading is
not what the bus protects. Speaking is (*ingress*): only a topic's publisher may put on it, only a
queryable's answerer may declare it and reply, only the robots may send requests, and each service
declares liveliness tokens only under its own kind. Robot users are per robot: the ``{robot_id}`` of a
robot's keys is its own id, so robot r2 cannot drive r1 or pose as it.

Pure: no files, no bus. :mod:`bimbot.shared.bus_credentials` writes the result into the router's config.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from .keyspace import Entry, Liveliness, Queryable, Topic
from .messages import KEY_SPACE, PHYSICS_SKIP_KEY

ROUTER_USER = "bus"
ANY_SITE = "*"
ROBOT_PREFIX = "robot-"

# The registry's speaker names (Topic.publisher, Queryable.answerer), one bus user each (robots: per id).
SPEAKERS = ("agent", "physics", "planner", "robot")
REQUESTERS = ("robot",)  # who may ask a queryable that takes a request (it changes the site)
# who may ask only some of them: the planner asks physics to skip its clock over a quiet site
SOME_REQUESTS = {"planner": (PHYSICS_SKIP_KEY,)}

# Zenoh 1.x access-control message kinds.
PUBLISH = ("put", "delete")
ANSWER = ("declare_queryable", "reply")
READ = ("declare_subscriber", "declare_liveliness_subscriber", "liveliness_query")
ALL_MESSAGES = (
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "reply",
    "declare_queryable",
    "liveliness_token",
    "liveliness_query",
    "declare_liveliness_subscriber",
)

_ID = re.compile(r"[A-Za-z0-9_-]+")  # a robot id: one key chunk, and a user name without ':'
_PART = re.compile(r"\{(\w+)\}")


@dataclass(frozen=True)
class BusUser:
    """One service role on a secured bus: its user name, the registry name it speaks as, its token kind."""

    name: str
    speaker: str | None  # a name of SPEAKERS; None: read-only
    token_kind: str | None  # its liveliness tokens live under alive/<token_kind>/
    robot_id: str | None = None

    @property
    def token_id(self) -> str:
        """The last chunk of its tokens' keys: its own id for a robot, any for the others."""
        return self.robot_id or "*"


def check_robot_id(robot_id: str) -> str:
    """``robot_id`` when it can be a key chunk and part of a user name; a ValueError otherwise."""
    if not _ID.fullmatch(robot_id):
        raise ValueError(f"robot id {robot_id!r}: use letters, digits, '_' and '-' only")
    return robot_id


def robot_user(robot_id: str) -> str:
    return f"{ROBOT_PREFIX}{check_robot_id(robot_id)}"


def bus_users(robot_ids: Sequence[str]) -> tuple[BusUser, ...]:
    """Every user of a secured bus with ``robot_ids`` (the router's own ``bus`` user not included)."""
    if len(set(robot_ids)) != len(robot_ids):
        raise ValueError(f"robot ids must differ: {', '.join(robot_ids)}")
    services = (
        BusUser("physics", "physics", "physics"),
        BusUser("planner", "planner", "planner"),
        BusUser("agents", "agent", "component"),
        BusUser("observer", None, "observer"),
        BusUser("monitor", None, "monitor"),
    )
    robots = tuple(BusUser(robot_user(rid), "robot", "robot", rid) for rid in robot_ids)
    return services + robots


def speakers_of(entry: Topic | Queryable) -> tuple[str, ...]:
    """Who speaks on ``entry`` by the registry: its publisher(s) or answerer; a ValueError for a name this
    module does not know (a new role needs a bus user before it can speak on a secured bus)."""
    names = tuple(entry.publisher.split("/")) if isinstance(entry, Topic) else (entry.answerer,)
    unknown = [name for name in names if name not in SPEAKERS]
    if unknown:
        raise ValueError(f"{entry.template}: no bus user speaks as {', '.join(unknown)}")
    return names


def key_expr(template: str, site: str, robot_id: str | None = None) -> str:
    """``template`` as an ACL key expression: the site filled, ``{robot_id}`` the robot's own id when
    given, every other part a ``*`` chunk."""

    def part(match: re.Match[str]) -> str:
        name = match.group(1)
        if name == "site":
            return site
        if name == "robot_id" and robot_id is not None:
            return robot_id
        return "*"

    return _PART.sub(part, template)


def _rule(rule_id: str, messages: Iterable[str], flow: str, key_exprs: Iterable[str]) -> dict[str, Any]:
    return {
        "id": rule_id,
        "messages": list(messages),
        "flows": [flow],
        "permission": "allow",
        "key_exprs": sorted(set(key_exprs)),
    }


def _speaking_rules(user: BusUser, site: str, key_space: Sequence[Entry]) -> list[dict[str, Any]]:
    """What ``user`` may say: put on its topics, answer its queryables, its tokens, its requests."""
    if user.speaker is None and user.token_kind is None:
        return []
    topics = [e for e in key_space if isinstance(e, Topic) and user.speaker in speakers_of(e)]
    served = [e for e in key_space if isinstance(e, Queryable) and user.speaker in speakers_of(e)]
    rules = []
    if topics:
        keys = (key_expr(t.template, site, user.robot_id) for t in topics)
        rules.append(_rule(f"publish:{user.name}", PUBLISH, "ingress", keys))
    if served:
        keys = (key_expr(q.template, site, user.robot_id) for q in served)
        rules.append(_rule(f"answer:{user.name}", ANSWER, "ingress", keys))
    if user.speaker in REQUESTERS:
        requests = [e for e in key_space if isinstance(e, Queryable) and e.request is not None]
        if requests:
            keys = (key_expr(q.template, site) for q in requests)
            rules.append(_rule(f"request:{user.name}", ("query",), "ingress", keys))
    elif user.speaker in SOME_REQUESTS:
        keys = (key_expr(template, site) for template in SOME_REQUESTS[user.speaker])
        rules.append(_rule(f"request:{user.name}", ("query",), "ingress", keys))
    if user.token_kind is not None:
        alive = next(e for e in key_space if isinstance(e, Liveliness))
        token = alive.template.format(site=site, kind=user.token_kind, id=user.token_id)
        rules.append(_rule(f"alive:{user.name}", ("liveliness_token",), "ingress", [token]))
    return rules


def access_control(
    robot_ids: Sequence[str], site: str = ANY_SITE, key_space: Sequence[Entry] = KEY_SPACE
) -> dict[str, Any]:
    """The router's ``access_control`` block for a site (``*``: any) with these robots: deny by default,
    allow what the module docstring says. Raises ValueError for a bad robot id or an unknown speaker."""
    if site != ANY_SITE and not _ID.fullmatch(site):
        raise ValueError(f"site {site!r}: a site slug is letters, digits, '_' and '-' ({ANY_SITE}: any site)")
    root = f"bimbot/{site}/**"
    asked = [e for e in key_space if isinstance(e, Queryable) and e.request is None]
    everyone_rules = [
        _rule("receive", ALL_MESSAGES, "egress", [root]),
        _rule("read", READ, "ingress", [root]),
        _rule("ask", ("query",), "ingress", (key_expr(q.template, site) for q in asked)),
    ]
    users = bus_users(robot_ids)
    rules = [*everyone_rules, _rule("route", ALL_MESSAGES, "ingress", [root])]
    subjects = [{"id": ROUTER_USER, "usernames": [ROUTER_USER]}]
    policies = [{"rules": ["receive", "route"], "subjects": [ROUTER_USER]}]
    for user in users:
        own = _speaking_rules(user, site, key_space)
        rules += own
        subjects.append({"id": user.name, "usernames": [user.name]})
        policies.append({"rules": [rule["id"] for rule in (*everyone_rules, *own)], "subjects": [user.name]})
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }


def may_put(acl: dict[str, Any], user: str, key: str) -> bool:
    """Whether ``user`` may put on the concrete ``key`` under ``acl`` (chunk wildcards ``*`` and a final
    ``**`` only, as :func:`access_control` writes them): for tests and for explaining a rule."""
    allowed = {
        rule_id for policy in acl["policies"] if user in policy["subjects"] for rule_id in policy["rules"]
    }
    return any(
        rule["id"] in allowed
        and "put" in rule["messages"]
        and "ingress" in rule["flows"]
        and any(_includes(pattern, key) for pattern in rule["key_exprs"])
        for rule in acl["rules"]
    )


def _includes(pattern: str, key: str) -> bool:
    want, got = pattern.split("/"), key.split("/")
    if want and want[-1] == "**":
        return len(got) >= len(want) - 1 and all(w in ("*", g) for w, g in zip(want[:-1], got, strict=False))
    return len(want) == len(got) and all(w in ("*", g) for w, g in zip(want, got, strict=True))
