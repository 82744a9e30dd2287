"""Sim time on the site's calendar: a project start date plus sim seconds, in working time when a working week
is given (``Mon-Fri 07:00-12:00 13:00-17:00``), else in elapsed time.

Sim time counts only the robots' work, so with a calendar a run's sim hour is an hour of the site's working
time: a task that starts at 16:50 and works 20 minutes finishes at 07:10 the next working day.
"""

from __future__ import annotations

import datetime as dt
import itertools
import re
from dataclasses import dataclass

from bimbot.shared.errors import UserError

DAY_NAMES = ("Mon", "Tue", "Wed", "Thu", "Fri", "Sat", "Sun")
MAX_DAYS = 3660  # a calendar that never reaches the time asked for (ten years of searching)
_PERIOD = re.compile(r"^(\d{1,2}):(\d{2})-(\d{1,2}):(\d{2})$")


@dataclass(frozen=True)
class WorkWeek:
    """Working days (0 Monday … 6 Sunday) and the same working periods on each of them."""

    days: frozenset[int]
    periods: tuple[tuple[dt.time, dt.time], ...]

    @property
    def text(self) -> str:
        days = ",".join(DAY_NAMES[day] for day in sorted(self.days))
        return f"{days} " + " ".join(f"{a:%H:%M}-{b:%H:%M}" for a, b in self.periods)


def parse_work_week(text: str) -> WorkWeek:
    """``'Mon-Fri 07:00-12:00 13:00-17:00'`` (days as a range or a comma list) → :class:`WorkWeek`."""
    words = text.split()
    if len(words) < 2:
        raise UserError(f"--calendar {text!r}: give days and periods, e.g. 'Mon-Fri 07:00-17:00'")
    days: set[int] = set()
    for part in words[0].split(","):
        first, _, last = part.partition("-")
        try:
            a = DAY_NAMES.index(first.capitalize()[:3])
            b = DAY_NAMES.index(last.capitalize()[:3]) if last else a
        except ValueError:
            raise UserError(f"--calendar {text!r}: {part!r} is not a day or day range (Mon-Fri)") from None
        days.update(range(a, b + 1) if a <= b else [*range(a, 7), *range(b + 1)])
    periods: list[tuple[dt.time, dt.time]] = []
    for word in words[1:]:
        match = _PERIOD.match(word)
        if not match:
            raise UserError(f"--calendar {text!r}: {word!r} is not a period like 07:00-17:00")
        h1, m1, h2, m2 = (int(group) for group in match.groups())
        try:
            start, end = dt.time(h1, m1), dt.time(h2, m2)
        except ValueError:
            raise UserError(f"--calendar {text!r}: {word!r} is not a time of day") from None
        if end <= start:
            raise UserError(f"--calendar {text!r}: {word!r} ends before it starts")
        periods.append((start, end))
    periods.sort()
    if any(prev[1] > nxt[0] for prev, nxt in itertools.pairwise(periods)):
        raise UserError(f"--calendar {text!r}: the periods overlap")
    return WorkWeek(frozenset(days), tuple(periods))


def site_time(start: dt.datetime, sim_s: float, week: WorkWeek | None = None) -> dt.datetime:
    """The date and time ``sim_s`` seconds of work after ``start`` (elapsed time without a calendar)."""
    if week is None:
        return start + dt.timedelta(seconds=sim_s)
    remaining = dt.timedelta(seconds=max(sim_s, 0.0))
    cursor = start
    for day_offset in range(MAX_DAYS):
        day = start.date() + dt.timedelta(days=day_offset)
        if day.weekday() not in week.days:
            continue
        for begin, end in week.periods:
            period_start = dt.datetime.combine(day, begin, tzinfo=start.tzinfo)
            period_end = dt.datetime.combine(day, end, tzinfo=start.tzinfo)
            if period_end <= cursor:
                continue
            cursor = max(cursor, period_start)
            if remaining <= period_end - cursor:
                return cursor + remaining
            remaining -= period_end - cursor
            cursor = period_end
    raise UserError(f"the calendar {week.text} has no working time within {MAX_DAYS} days of {start}")


def parse_start(text: str) -> dt.datetime:
    """``--start 2027-03-01T07:00`` → datetime (naive: the site's local time)."""
    try:
        return dt.datetime.fromisoformat(text)
    except ValueError:
        raise UserError(f"--start {text!r}: not a date and time like 2027-03-01T07:00") from None
