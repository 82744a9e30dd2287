"""The table ``bimbot run`` prints at the end: every component not constructed, with name, short GUID,
state, reason code and message, in planned order; nothing when all is built."""

from __future__ import annotations

from bimbot.run.table import not_built_table

ENDING = "stopped by SIGTERM after 11 s wall, at sim 10.0 s, with 1/4 constructed"


def _component(guid: str, name: str, state: str, index: int, reason: dict | None) -> dict:
    return {
        "guid": guid,
        "name": name,
        "ifc_class": "IfcFooting",
        "state": state,
        "sequence_index": index,
        "reason": reason,
    }


REPORT = {
    "ending": {"how": "interrupted", "code": "interrupted", "message": ENDING, "details": []},
    "components": [
        _component(
            "3eV89hRdQ1Bx5b6PaC9rjw",
            "Beam A1-A2",
            "blocked",
            3,
            {
                "code": "blocked_by",
                "message": "predecessor 1ctEyZqY… was not built (too_heavy)",
                "guid": "1ctEyZqYn3Ov0qQ8GwbUTf",
                "robot_id": None,
            },
        ),
        _component(
            "1ctEyZqYn3Ov0qQ8GwbUTf",
            "Footing A1",
            "failed",
            0,
            {
                "code": "too_heavy",
                "message": "Footing A1 weighs 5,760 kg; the robot carries 1,000 kg",
                "guid": None,
                "robot_id": None,
            },
        ),
        _component("0r1e7X$sCbW9Zz2Ms0mWcF", "Footing A2", "constructed", 1, None),
        _component(
            "0T1QiaRO4mQe8b2k0fjN8H",
            "Column A2",
            "picking",
            2,
            {
                "code": "interrupted",
                "message": f"{ENDING}; it was picking (robot r1)",
                "guid": None,
                "robot_id": "r1",
            },
        ),
    ],
}


def test_the_table_names_each_component_not_built_with_its_guid_state_code_and_message() -> None:
    table = not_built_table(REPORT)
    lines = table.splitlines()
    assert lines[0] == "not built: 3 component(s): 1 blocked_by, 1 interrupted, 1 too_heavy"
    assert lines[1].split() == ["component", "guid", "state", "reason", "why"]
    beam, column, footing = lines[2:]  # by reason code (one each: by code), planned order within a code
    assert footing.split()[:5] == ["Footing", "A1", "1ctEyZqYn3Ov0qQ8GwbUTf", "failed", "too_heavy"]
    assert footing.endswith("Footing A1 weighs 5,760 kg; the robot carries 1,000 kg")
    assert "0T1QiaRO" in column and "interrupted" in column
    assert column.endswith("it was picking (robot r1)")  # the ending itself is printed once, above
    assert "3eV89hRd" in beam and "blocked_by" in beam
    assert "0r1e7X$s" not in table  # constructed


def test_columns_line_up() -> None:
    header, _, column, footing = not_built_table(REPORT).splitlines()[1:]
    assert header.index("guid") == footing.index("1ctEyZqY") == column.index("0T1QiaRO")
    assert header.index("why") == footing.index("Footing A1 weighs") == column.index("it was picking")


def test_nothing_is_printed_when_every_component_is_constructed() -> None:
    report = {"components": [_component("0r1e7X$sCbW9Zz2Ms0mWcF", "Footing A2", "constructed", 0, None)]}
    assert not_built_table(report) == ""


def test_many_components_blocked_by_one_failed_component_take_one_row() -> None:
    root = "1ctEyZqYn3Ov0qQ8GwbUTf"
    blocked = [
        {
            "guid": f"0Blocked{i:014d}",
            "name": f"Beam {i}",
            "state": "blocked",
            "sequence_index": 10 + i,
            "reason": {"code": "blocked_by", "message": f"it rests on {root}", "guid": root},
        }
        for i in range(5)
    ]
    report = {**REPORT, "components": [*REPORT["components"], *blocked]}
    table = not_built_table(report)
    lines = table.splitlines()
    assert lines[0] == "not built: 8 component(s): 6 blocked_by, 1 interrupted, 1 too_heavy"  # most first
    [group] = [line for line in lines if "6 components" in line]  # the report's own beam rests on it too
    assert "blocked_by" in group and "Beam A1-A2, Beam 0, Beam 1 and 3 more" in group
    assert f"on Footing A1 ({root})" in group  # the failed component by name, not by GUID alone
    # and why it was not built, as its own row says (a trial had to find the root's row to learn that)
    assert f"on Footing A1 ({root}), which was not built (too_heavy): Beam A1-A2" in group
    assert "0Blocked" not in table and "3eV89hRd" not in table
    assert len(lines) == 5  # count, header, the failed footing, the interrupted column, the group


def test_a_long_name_keeps_its_end_where_revit_puts_the_element_id() -> None:
    names = [
        "M_W-Wide Flange-Column:W10X49:Structural Column:W10X49:412345",
        "M_W-Wide Flange-Column:W10X49:Structural Column:W10X49:412346",
    ]
    report = {
        "components": [
            _component(f"guid{index}", name, "failed", index, {"code": "too_heavy", "message": "heavy"})
            for index, name in enumerate(names)
        ]
    }
    lines = not_built_table(report).splitlines()[2:]
    assert [line.split("  guid")[0].strip() for line in lines] == [
        "M_W-Wide Flange-Column:W10X49:S…mn:W10X49:412345",
        "M_W-Wide Flange-Column:W10X49:S…mn:W10X49:412346",
    ]


def test_other_components_named_by_guid_in_a_message_get_their_names() -> None:
    support = "2mLB0dQuXv1Ub0xTLNyjS4"
    unstable = _component(
        "0T1QiaRO4mQe8b2k0fjN8H",
        "Column A2",
        "failed",
        1,
        {
            "code": "unstable",
            "message": f"it moved 0.300 m and came to rest on {support}, 0r1e7X$sCbW9Zz2Ms0mWcF",
        },
    )
    beam = _component(support, "Beam A1-A2", "constructed", 0, None)
    footing = _component("0r1e7X$sCbW9Zz2Ms0mWcF", "Footing A2", "constructed", 2, None)
    table = not_built_table({"components": [unstable, beam, footing]})
    assert f"came to rest on Beam A1-A2 ({support}), Footing A2 (0r1e7X$sCbW9Zz2Ms0mWcF)" in table
    already = _component(
        "3eV89hRdQ1Bx5b6PaC9rjw",
        "Beam B",
        "failed",
        3,
        {"code": "misplaced", "message": f"Beam A1-A2 ({support})"},
    )
    assert f"Beam A1-A2 (Beam A1-A2 ({support}))" not in not_built_table({"components": [already, beam]})
    after = _component(
        "3eV89hRdQ1Bx5b6PaC9rjw",
        "Beam B",
        "blocked",
        3,
        {"code": "blocked_by", "message": f"on {support} (Beam A1-A2)"},
    )
    assert f"on {support} (Beam A1-A2)" in not_built_table({"components": [after, beam]})  # named already
    # a GUID given to an option of the advised command stays bare, so the command runs as pasted (the
    # restaurant's advice read "--exclude Signage_all:…:711229 (21TEK1_hD0xO7FHM1D4Y0W)")
    advice = f"rests on {support}; leave one out: bimbot convert MODEL.ifc -o OUT/ --exclude {support}"
    clash = _component(
        "3eV89hRdQ1Bx5b6PaC9rjw", "Beam B", "failed", 3, {"code": "unstable", "message": advice}
    )
    table = not_built_table({"components": [clash, beam]})
    assert f"rests on Beam A1-A2 ({support})" in table and f"-o OUT/ --exclude {support}" in table


def test_rows_follow_the_tally_and_alike_rows_take_one() -> None:
    interrupted = [
        _component(
            f"0Planned{i:014d}",
            f"Beam {i}",
            "planned",
            10 + i,
            {"code": "interrupted", "message": "it was planned"},
        )
        for i in range(5)
    ]
    heavy = [
        _component(
            f"0Heavy{i:016d}", f"Slab {i}", "failed", 20 + i, {"code": "too_heavy", "message": f"{i} t"}
        )
        for i in range(2)
    ]
    table = not_built_table({"components": [*heavy, *interrupted]})
    lines = table.splitlines()
    assert lines[0] == "not built: 7 component(s): 5 interrupted, 2 too_heavy"
    assert [line.split()[0:2] for line in lines[2:]] == [["5", "components"], ["Slab", "0"], ["Slab", "1"]]
    assert (
        lines[2].endswith("it was planned: Beam 0, Beam 1, Beam 2 and 2 more") and "(report.json)" in lines[2]
    )


def test_rows_that_differ_only_in_their_figures_take_one_with_the_ranges() -> None:
    """The Revit hub's 69 out_of_reach rows differed only in a height (16 of them shown, each with the same
    long advice): one row, each differing figure as its range, the figures that agree as they are."""
    high = [
        _component(
            f"0High{i:017d}",
            f"Column {i}",
            "failed",
            i,
            {
                "code": "out_of_reach",
                "message": f"target top at {3.9 + 0.1 * i:.2f} m is above 3.50 m; 1,200 kg",
            },
        )
        for i in range(5)
    ]
    heavy = [
        _component(
            f"0Heavy{i:016d}", f"Slab {i}", "failed", 20 + i, {"code": "too_heavy", "message": f"{i} t"}
        )
        for i in range(2)
    ]
    lines = not_built_table({"components": [*high, *heavy]}).splitlines()
    assert [line.split()[0:2] for line in lines[2:]] == [["5", "components"], ["Slab", "0"], ["Slab", "1"]]
    assert (
        "target top at 3.90–4.30 m is above 3.50 m; 1,200 kg: Column 0, Column 1, Column 2 and 2 more"
        in (lines[2])
    )


def test_alike_messages_take_one_row_with_each_differing_figure_as_its_range() -> None:
    """Alike rows are one row whose figures are ranges; a range in each message becomes one range (a new
    user read "spans 127.5–136.1–144.2–148.5 m" in fleet check's summary of a Revit office)."""
    from bimbot.run.table import with_ranges

    spans = ["its footprint spans 127.5–144.2 m from r5", "its footprint spans 136.1–148.5 m from r5"]
    assert with_ranges(spans) == "its footprint spans 127.5–148.5 m from r5"
    assert (
        with_ranges(["top at 4.46 m above 3.5 m", "top at 3.92 m above 3.5 m"])
        == "top at 3.92–4.46 m above 3.5 m"
    )
    assert (
        with_ranges(["lifts 88 kg to 15.4 m", "lifts 7,835 kg to 60.0 m"])
        == "lifts 88–7,835 kg to 15.4–60.0 m"
    )
