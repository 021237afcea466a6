"""Loading chains from ROS parameters: shapes accepted, every malformed input refused."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from support.kinematics import CONFIG

from amr_kinematics.config import ChainConfig, flatten_parameters, load_chain_set
from amr_kinematics.errors import ChainConfigError, KinematicsError

SHIPPED = ["arm5", "ull5", "ull3", "rr2", "manipulator3", "ur5", "panda"]


def good() -> dict:
    """A valid nested parameter dict with two chains."""
    return {
        "chains": ["two", "arm"],
        "two": {
            "convention": "planar",
            "joint_names": ["a", "b"],
            "types": ["revolute", "revolute"],
            "theta": [0.0, 0.0],
            "a": [1.0, 1.0],
            "lower": [-3.0, -3.0],
            "upper": [3.0, 3.0],
            "solver": "analytic",
        },
        "arm": {
            "convention": "standard_dh",
            "joint_names": ["j1", "j2", "j3"],
            "types": ["revolute", "prismatic", "revolute"],
            "d": [0.1, 0.0, 0.0],
            "theta": [0.0, 0.0, 0.0],
            "a": [0.0, 0.2, 0.1],
            "alpha": [1.5, 0.0, 0.0],
            "lower": [-3.0, 0.0, -3.0],
            "upper": [3.0, 0.5, 3.0],
        },
    }


def flat(params: dict) -> dict:
    return flatten_parameters(params)


def refused(params, chain, key, match=None) -> ChainConfigError:
    with pytest.raises(ChainConfigError) as info:
        load_chain_set(params)
    assert info.value.chain == chain
    assert info.value.key == key
    if match:
        assert match in str(info.value)
    return info.value


def test_shipped_file_loads_every_chain(chain_set):
    assert list(chain_set) == SHIPPED
    for name, config in chain_set.items():
        assert isinstance(config, ChainConfig) and config.name == name
        assert config.chain.within_limits(config.home)


def test_yaml_nested_and_rclpy_flat_forms_agree(raw_params):
    nested = load_chain_set(raw_params)
    dotted = load_chain_set(flat(raw_params))  # what rclpy's get_parameters_by_prefix gives
    assert list(nested) == list(dotted)
    for name in nested:
        np.testing.assert_array_equal(nested[name].chain.lower, dotted[name].chain.lower)
        assert nested[name].solver_options == dotted[name].solver_options


def test_file_loads_through_an_rclpy_node():
    """The path the node takes: rcl's parser (it refuses mixed int/float lists), then
    the flat parameter dict of a node named ik_service."""
    rclpy = pytest.importorskip("rclpy")
    from rclpy.node import Node

    context = rclpy.Context()
    rclpy.init(args=["--ros-args", "--params-file", str(CONFIG)], context=context)
    try:
        node = Node(
            "ik_service",
            context=context,
            allow_undeclared_parameters=True,
            automatically_declare_parameters_from_overrides=True,
        )
        values = {name: p.value for name, p in node.get_parameters_by_prefix("").items()}
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
    configs = load_chain_set(values)
    assert list(configs) == SHIPPED
    assert configs["ur5"].tolerance == 1e-5 and configs["arm5"].options_for("dls")["restarts"] is False


def test_other_node_parameters_and_unlisted_chains_are_ignored():
    params = flat(good())
    params.update({"use_sim_time": False, "spare.types": ["bogus"]})
    assert list(load_chain_set(params)) == ["two", "arm"]


def test_coupling_parallel_arrays(chain_set):
    chain = chain_set["arm5"].chain
    (coupling,) = chain.couplings
    assert coupling.joint == 4 and coupling.offset == pytest.approx(-math.pi / 2)
    np.testing.assert_array_equal(chain.free, [0, 1, 2, 3])
    q = chain.apply_coupling([0.0, 0.1, 0.2, 0.3, 0.0])
    assert q[4] == pytest.approx(-math.pi / 2 - 0.6) and chain.couplings_hold(q)
    clipped = chain.apply_coupling([0.0, 1.0, 1.0, 1.0, 0.0])  # -pi/2 - 3 is below -pi
    assert clipped[4] == -math.pi and not chain.couplings_hold(clipped)


def test_defaults_and_options(chain_set):
    arm5 = chain_set["arm5"]
    assert arm5.solver == "dls" and arm5.max_iterations == 100 and arm5.timeout == 0.05
    assert arm5.options_for("dls")["coupling_update"] == "project"
    assert "coupling_update" in arm5.options_for("pinv") and "restarts" not in arm5.options_for("pinv")
    assert chain_set["ull5"].options_for("ccd") == {}


# --- one test per kind of malformed input -------------------------------------------------


def test_missing_chains_list():
    params = good()
    del params["chains"]
    refused(params, None, "chains")


def test_chain_name_with_dot():
    params = good()
    params["chains"] = ["two", "a.b"]
    refused(params, None, "chains", "without dots")


def test_missing_required_key():
    params = good()
    del params["arm"]["alpha"]
    refused(params, "arm", "arm.alpha", "required")


def test_length_mismatch():
    params = good()
    params["arm"]["theta"] = [0.0, 0.0]
    refused(params, "arm", "arm.theta", "3 joints")


def test_lower_above_upper():
    params = good()
    params["arm"]["lower"][1] = 0.6
    refused(params, "arm", "arm.lower", "lower 0.6 > upper 0.5")


def test_unknown_joint_type():
    params = good()
    params["arm"]["types"][1] = "spherical"
    refused(params, "arm", "arm.types", "spherical")


def test_unknown_convention():
    params = good()
    params["arm"]["convention"] = "dh"
    refused(params, "arm", "arm.convention", "unknown convention")


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_number(bad):
    params = good()
    params["arm"]["d"][0] = bad
    refused(params, "arm", "arm.d", "finite")


@pytest.mark.parametrize("empty", [[], None])  # rclpy reads `types: []` as an unset parameter (None)
def test_chain_without_joints(empty):
    params = good()
    params["arm"].update(types=empty, joint_names=[], d=[], theta=[], a=[], alpha=[], lower=[], upper=[])
    refused(params, "arm", "arm.types", "a chain needs at least one joint")


@pytest.mark.parametrize(
    "key, value, match",
    [
        ("tolerance", 1e155, "(0, 1e+06]"),
        ("tolerance", math.inf, "finite"),
        ("orientation_tolerance", 4.0, "(0, 3.14159]"),
        ("timeout", 61.0, "(0, 60]"),
    ],
)
def test_default_outside_its_range(key, value, match):
    params = good()
    params["arm"][key] = value
    refused(params, "arm", f"arm.{key}", match)


def test_integer_where_float_required_says_how_to_fix():
    params = good()
    params["arm"]["a"] = [0.0, 1, 0.1]  # rclpy would refuse this mixed list outright
    error = refused(params, "arm", "arm.a", "write 1.0")
    assert "integer" in str(error)


def test_integer_scalar_where_float_required():
    params = good()
    params["arm"]["tolerance"] = 1
    refused(params, "arm", "arm.tolerance", "write 1.0")


def test_string_where_list_required():
    params = good()
    params["arm"]["joint_names"] = "j1 j2 j3"
    refused(params, "arm", "arm.joint_names", "list of non-empty strings")


def test_unknown_key_is_a_typo():
    params = good()
    params["arm"]["uper"] = [3.0, 0.5, 3.0]
    refused(params, "arm", "arm.uper", "unknown key")


def test_duplicate_joint_names():
    params = good()
    params["arm"]["joint_names"] = ["j1", "j1", "j3"]
    refused(params, "arm", "arm.joint_names", "unique")


def test_planar_chain_with_dh_keys():
    params = good()
    params["two"]["alpha"] = [0.0, 0.0]
    refused(params, "two", "two.alpha", "theta and a only")


def test_incomplete_coupling():
    params = good()
    params["arm"]["coupled_joint"] = ["j3"]
    refused(params, "arm", "arm.coupling_offset", "coupling needs")


def test_coupling_coefficients_wrong_length():
    params = good()
    params["arm"].update(coupled_joint=["j3"], coupling_offset=[0.0], coupling_coefficients=[1.0, 0.0])
    refused(params, "arm", "arm.coupling_coefficients", "3 coefficients per coupled joint")


def test_coupling_of_unknown_joint():
    params = good()
    params["arm"].update(coupled_joint=["j9"], coupling_offset=[0.0], coupling_coefficients=[1.0, 0.0, 0.0])
    refused(params, "arm", "arm.coupled_joint", "j9")


def test_coupling_on_a_coupled_joint():
    params = good()
    params["arm"].update(coupled_joint=["j3"], coupling_offset=[0.0], coupling_coefficients=[1.0, 0.0, 1.0])
    refused(params, "arm", "arm.coupling_coefficients", "independent joints")


def test_transform_with_wrong_length():
    params = good()
    params["arm"]["tool_xyz_rpy"] = [0.0, 0.0, 0.1]
    refused(params, "arm", "arm.tool_xyz_rpy", "6 values")


def test_tilted_base_on_a_planar_chain():
    params = good()
    params["two"]["base_xyz_rpy"] = [0.0, 0.0, 0.0, 0.3, 0.0, 0.0]
    refused(params, "two", "two.base_xyz_rpy", "only rotate about z")


def test_home_outside_limits():
    params = good()
    params["arm"]["home"] = [0.0, 0.9, 0.0]
    refused(params, "arm", "arm.home", "outside the joint limits")


def test_home_wrong_length():
    params = good()
    params["arm"]["home"] = [0.0, 0.1]
    refused(params, "arm", "arm.home", "3 joints")


def test_unknown_default_solver():
    params = good()
    params["arm"]["solver"] = "fabrik"
    refused(params, "arm", "arm.solver", "unknown solver")


def test_default_solver_not_valid_for_the_chain():
    params = good()
    params["arm"]["solver"] = "analytic"
    refused(params, "arm", "arm.solver", "planar 2R")


def test_bad_solver_option():
    params = good()
    params["arm"]["damping"] = -0.1
    refused(params, "arm", "arm.damping", "damping")


def test_bad_integer_default():
    params = good()
    params["arm"]["max_iterations"] = 0
    refused(params, "arm", "arm.max_iterations", "must be positive")


def test_all_or_nothing():
    params = good()
    params["arm"]["upper"] = [3.0, 0.5]  # the second chain is bad: no chain comes back
    with pytest.raises(ChainConfigError):
        result = load_chain_set(params)
        pytest.fail(f"half-loaded: {result}")


def test_errors_are_value_errors():
    assert issubclass(ChainConfigError, KinematicsError) and issubclass(KinematicsError, ValueError)


def test_parameters_under_the_node_name():
    nested = {"ik_service": {"ros__parameters": copy.deepcopy(good())}}
    assert list(load_chain_set(nested)) == ["two", "arm"]
