"""ParameterSpec: types, widening, limits, choices and checks, with messages naming the key."""

import pytest

from amr_util.parameter_spec import ParameterSpec, field_docs, problems_of


def test_kind_comes_from_the_default_and_integers_widen_to_floats():
    assert ParameterSpec("kp", 4.0).coerce(3) == 3.0
    assert ParameterSpec("start", [], kind="float_array").coerce([1, 2, 3]) == [1.0, 2.0, 3.0]
    assert ParameterSpec("beams", 240).kind == "int"


@pytest.mark.parametrize("spec, value, words", [
    (ParameterSpec("kp", 4.0, minimum=0.0, maximum=100.0), "abc", "kp: must be a number, got 'abc'"),
    (ParameterSpec("kp", 4.0, minimum=0.0, maximum=100.0), 101.0, "kp: must be in [0, 100], got 101.0"),
    (ParameterSpec("kp", 4.0), float("nan"), "kp: must be finite"),
    (ParameterSpec("beams", 240, minimum=1), True, "beams: must be an integer, got True"),
    (ParameterSpec("wall", "right", choices=("right", "left")), "up", "wall: must be one of right, left, got 'up'"),
    (ParameterSpec("names", ["a"]), ["a", 1], "names: must be a string, got 1"),
    (ParameterSpec("world", "w", check=lambda v: "no such file" if v == "x" else None), "x", "world: no such file"),
])
def test_bad_values_are_refused_naming_key_and_rule(spec, value, words):
    with pytest.raises(ValueError) as error:
        spec.coerce(value)
    assert str(error.value) == words or str(error.value).startswith(words)


def test_problems_are_all_reported_at_once():
    specs = [ParameterSpec("dt", 0.05, minimum=0.001), ParameterSpec("mode", "a", choices=("a", "b")),
             ParameterSpec("ok", 1)]
    problems = problems_of(specs, {"dt": -1.0, "mode": "c", "ok": 2})
    assert [p.split(":")[0] for p in problems] == ["dt", "mode"]


def test_field_docs_read_the_docstring_under_each_field():
    from amr_control.wall_follower_config import WallFollowerConfig

    docs = field_docs(WallFollowerConfig)
    assert docs["kp"] == "rad/s per m of distance error."
    assert "dt" in docs and "simulation" in docs
