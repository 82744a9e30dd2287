"""The study's grid and each run's ``bimbot run`` command line (pure)."""

from __future__ import annotations

from pathlib import Path

import pytest

from bimbot.study.grid import DERIVE, StudyRun, run_accepts_seed, run_arguments, study_grid, unique_labels


def test_grid_is_every_fleet_times_every_sequence_times_every_seed_fleets_outermost() -> None:
    fleets = [Path("/f/a.toml"), Path("/f/b.toml")]
    grid = study_grid(fleets, seeds=3, sequences=["/s/one.xml", DERIVE])
    assert len(grid) == 2 * 2 * 3
    assert [run.name for run in grid[:4]] == ["a-one-0", "a-one-1", "a-one-2", "a-derive-0"]
    assert {run.fleet for run in grid[6:]} == {Path("/f/b.toml")}
    assert len({run.name for run in grid}) == len(grid)  # one run folder each


def test_without_sequences_the_runs_use_the_builds_own_and_their_names_omit_it() -> None:
    grid = study_grid([Path("carriers.toml")], seeds=2)
    assert [(run.name, run.sequence, run.sequence_label) for run in grid] == [
        ("carriers-0", None, "build"),
        ("carriers-1", None, "build"),
    ]


def test_the_seeds_start_at_bimbot_run_s_own_so_the_first_run_is_the_one_a_user_has_seen() -> None:
    from bimbot.command_line import build_parser

    default_seed = build_parser(["run", "b"]).parse_args(["run", "b"]).seed
    assert [run.seed for run in study_grid([Path("a.toml")], seeds=2)] == [default_seed, default_seed + 1]
    assert [run.seed for run in study_grid([Path("a.toml")], seeds=2, first_seed=5)] == [5, 6]
    argv = ["study", "b", "--fleet", "a.toml", "-o", "o", "--first-seed", "5"]
    assert build_parser(argv).parse_args(argv).first_seed == 5


def test_two_fleet_files_of_one_name_get_distinct_labels() -> None:
    assert unique_labels(["x/fleet.toml", "y/fleet.toml", "z/my fleet.toml"]) == [
        "fleet",
        "fleet-2",
        "my_fleet",
    ]


def test_a_grid_without_seeds_or_with_an_unknown_fidelity_is_refused() -> None:
    with pytest.raises(ValueError, match="at least one seed"):
        study_grid([Path("a.toml")], seeds=0)
    with pytest.raises(ValueError, match="fidelity"):
        study_grid([Path("a.toml")], seeds=1, fidelity="cartoon")


def test_run_arguments_name_the_fleet_folder_limit_and_sequence_and_the_seed_only_when_it_can_pass() -> None:
    run = StudyRun(fleet=Path("/f/a.toml"), fleet_label="a", seed=7, sequence=DERIVE, sequence_label=DERIVE)
    arguments = run_arguments(Path("/b"), run, Path("/o/runs/a-derive-7"), 300.0, pass_seed=False)
    assert arguments[:2] == ["run", "/b"]
    assert arguments[arguments.index("--fleet") + 1] == "/f/a.toml"
    assert arguments[arguments.index("--run-dir") + 1] == "/o/runs/a-derive-7"
    assert arguments[arguments.index("--timeout-s") + 1] == "300.0"
    assert "--derive" in arguments and "-q" in arguments and "--seed" not in arguments
    with_seed = run_arguments(Path("/b"), run, Path("/o"), 300.0, pass_seed=True)
    assert with_seed[with_seed.index("--seed") + 1] == "7"
    schedule = StudyRun(fleet=Path("/f/a.toml"), fleet_label="a", seed=1, sequence="/s/p6.xml")
    arguments = run_arguments(Path("/b"), schedule, Path("/o"), 300.0, pass_seed=False)
    assert arguments[arguments.index("--sequence") + 1] == "/s/p6.xml"


def test_whether_bimbot_run_takes_a_seed_is_read_from_its_own_parser() -> None:
    from bimbot.command_line import build_parser

    parser = build_parser(["run", "x"])
    run_parser = parser._subparsers._group_actions[0].choices["run"]  # type: ignore[union-attr]
    assert run_accepts_seed() == ("--seed" in run_parser._option_string_actions)
