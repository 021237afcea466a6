"""ParameterSpec: types, widening, limits, choices and checks, with messages naming the key."""

from dataclasses import dataclass, field

import pytest

from amr_util.parameter_spec import (
    Config,
    ConfigError,
    ParameterSpec,
    field_docs,
    parameter,
    parameter_like,
    problems_of,
)


def test_kind_comes_from_the_default_and_integers_widen_to_floats():
    assert ParameterSpec("kp", 4.0).coerce(3) == 3.0
    assert ParameterSpec("start", [], kind="float_array").coerce([1, 2, 3]) == [1.0, 2.0, 3.0]
    assert ParameterSpec("beams", 240).kind == "int"


@pytest.mark.parametrize(
    "spec, value, words",
    [
        (ParameterSpec("kp", 4.0, minimum=0.0, maximum=100.0), "abc", "kp: must be a number, got 'abc'"),
        (ParameterSpec("kp", 4.0, minimum=0.0, maximum=100.0), 101.0, "kp: must be in [0, 100], got 101.0"),
        (ParameterSpec("kp", 4.0), float("nan"), "kp: must be finite"),
        (ParameterSpec("beams", 240, minimum=1), True, "beams: must be an integer, got True"),
        (ParameterSpec("wall", "right", choices=("right", "left")), "up", "wall: must be one of right, left, got 'up'"),
        (ParameterSpec("names", ["a"]), ["a", 1], "names: must be a string, got 1"),
        (ParameterSpec("world", "w", check=lambda v: "no such file" if v == "x" else None), "x", "world: no such file"),
    ],
)
def test_bad_values_are_refused_naming_key_and_rule(spec, value, words):
    with pytest.raises(ValueError) as error:
        spec.coerce(value)
    assert str(error.value) == words or str(error.value).startswith(words)


def test_problems_are_all_reported_at_once():
    specs = [
        ParameterSpec("dt", 0.05, minimum=0.001),
        ParameterSpec("mode", "a", choices=("a", "b")),
        ParameterSpec("ok", 1),
    ]
    problems = problems_of(specs, {"dt": -1.0, "mode": "c", "ok": 2})
    assert [p.split(":")[0] for p in problems] == ["dt", "mode"]


def test_field_docs_read_the_docstring_under_each_field():
    from amr_control.wall_follower_config import WallFollowerConfig

    docs = field_docs(WallFollowerConfig)
    assert docs["kp"] == "rad/s per m of distance error."
    assert "dt" in docs and "simulation" in docs


# -- configurations whose fields are parameters ----------------------------------------------------


@dataclass(frozen=True)
class Wheel(Config):
    radius: float = parameter(0.033, above=0.0, maximum=1.0)
    """m."""


@dataclass(frozen=True)
class Robot(Config):
    gain: float = parameter(2.0, minimum=0.0, maximum=10.0, live=True)
    """1/s."""
    mode: str = parameter("fast", choices=("fast", "slow"))
    """how it goes."""
    start: tuple | None = parameter(None, kind="float_array", check=lambda v: None if len(v) in (0, 3) else "3 values")
    """[x, y, theta] or not given."""
    wheel: Wheel = field(default_factory=Wheel)
    wheel_radius: float = parameter_like(Wheel, "radius", live=True)

    def validate(self) -> None:
        if self.mode == "slow" and self.gain > 5.0:
            raise ConfigError(f"gain: at most 5 when slow, got {self.gain}")


def test_a_config_states_each_parameter_once_and_derives_its_specs():
    specs = {spec.name: spec for spec in Robot.parameter_specs()}
    assert list(specs) == ["gain", "mode", "start", "wheel.radius", "wheel_radius"]
    assert specs["gain"].description == "1/s." and specs["gain"].live and specs["gain"].range_text == "in [0, 10]"
    assert specs["wheel.radius"].range_text == "in (0, 1]" and not specs["wheel.radius"].live
    assert specs["wheel_radius"].description == "m." and specs["wheel_radius"].live  # the other field's truth
    assert specs["start"].kind == "float_array" and specs["start"].default == []


def test_construction_and_from_params_validate_naming_the_key():
    assert Robot.from_params({"gain": 3, "wheel.radius": 0.05}).gain == 3.0
    assert Robot.from_params({"wheel": {"radius": 0.05}}).wheel.radius == 0.05
    for params, words in [
        ({"gain": 11.0}, "gain: must be in [0, 10], got 11.0"),
        ({"gain": -1.0}, "gain: must be >= 0 (in [0, 10]), got -1.0"),
        ({"wheel.radius": 0.0}, "wheel.radius: must be positive (in (0, 1]), got 0.0"),
        ({"mode": "slow", "gain": 6.0}, "gain: at most 5 when slow"),
        ({"start": [1.0]}, "start: 3 values"),
        ({"gian": 1.0}, "gian: unknown parameter (known: gain, mode, start, wheel.*, wheel_radius)"),
        ({"wheel.radius": "big"}, "wheel.radius: must be a number, got 'big'"),
    ]:
        with pytest.raises(ConfigError) as error:
            Robot.from_params(params)
        assert str(error.value).startswith(words)
    with pytest.raises(ConfigError, match="radius: must be positive"):
        Wheel(radius=0.0)


def test_params_round_trip_and_structural_changes_are_named():
    robot = Robot.from_params({"start": [1, 2, 3]})
    assert robot.start == (1.0, 2.0, 3.0) and Robot.from_params({"start": []}).start is None
    assert Robot.from_params(robot.as_params()) == robot
    other = Robot.from_params({"start": [1, 2, 3], "gain": 1.0, "mode": "slow", "wheel.radius": 0.1})
    assert robot.structural_changes(other) == ["mode", "wheel.radius"]  # gain is live


def test_an_annotation_that_contradicts_the_default_is_refused():
    @dataclass(frozen=True)
    class Wrong(Config):
        kp: float = parameter(4)

    with pytest.raises(TypeError, match="Wrong.kp: annotated float, but its default 4 is int"):
        Wrong.parameter_specs()
