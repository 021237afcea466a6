"""amr-maze: the maze generator as a command that writes world files the suite loads."""

from __future__ import annotations

import pytest
import yaml

from amr_maps.maze_command import main
from amr_maps.maze_families import FAMILIES, generate
from amr_maps.world import load_world


def test_writes_one_loadable_world_per_seed_with_the_generated_geometry(tmp_path, capsys):
    assert (
        main(
            [
                "loops",
                "--seed",
                "3",
                "--count",
                "2",
                "--size",
                "3",
                "--set",
                "loop_fraction=0.25",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    written = sorted(p.name for p in tmp_path.glob("*.yaml"))
    assert written == ["loops_3.yaml", "loops_4.yaml"]
    printed = capsys.readouterr().out
    for seed in (3, 4):
        path = tmp_path / f"loops_{seed}.yaml"
        expected = generate("loops", seed, size=3.0, loop_fraction=0.25)
        assert yaml.safe_load(path.read_text()) == expected, "the file holds exactly what the generator drew"
        world = load_world(path)
        assert world.name == f"loops_{seed}" and world.goal is not None
        assert f"wrote {path}" in printed


def test_the_same_arguments_write_the_same_file(tmp_path):
    for out in ("a", "b"):
        assert main(["bends", "--seed", "11", "--set", "bends=3", "--out", str(tmp_path / out)]) == 0
    assert (tmp_path / "a" / "bends_11.yaml").read_bytes() == (tmp_path / "b" / "bends_11.yaml").read_bytes()


def test_all_writes_one_maze_of_each_family(tmp_path):
    assert main(["all", "--seed", "1", "--out", str(tmp_path)]) == 0
    assert sorted(p.stem for p in tmp_path.glob("*.yaml")) == sorted(f"{family}_1" for family in FAMILIES)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["spiral"], "unknown maze family 'spiral'"),
        (["loops", "--set", "loop_fractio=0.3"], "unknown option 'loop_fractio'"),
        (["loops", "--set", "loop_fraction=lots"], "'lots' is not a number"),
        (["perfect", "--size", "80"], "option size must be a number in"),
        (["perfect", "--count", "0"], "--count must be at least 1"),
        ([], "a family is required"),
    ],
)
def test_bad_arguments_exit_2_naming_the_problem(argv, message, tmp_path, capsys):
    assert main([*argv, "--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.glob("*.yaml"))


def test_list_names_every_family_and_its_options(capsys):
    assert main(["--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(":")[0] for line in lines] == list(FAMILIES)
    assert "loops: size, width, thickness, hand, loop_fraction" in lines
