"""Bringup files: the shipped ones, the arguments they become, and the errors that name file and key."""

import inspect
from pathlib import Path

import pytest
import yaml

from amr_bringup.bringup import NODE_CLASSES, check_composable
from amr_bringup.stack_config import (
    BringupError,
    NodeSpec,
    check_installed,
    find_bringup,
    load_bringup,
    parse_bringup,
    yaml_scalar,
)
from amr_util.managed_node import ManagedNode

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted(path.stem for path in (ROOT / "config" / "bringup").glob("*.yaml"))


def test_the_stacks_are_shipped():
    assert SHIPPED == [
        "fleet_navigation",
        "fleet_sim",
        "ik_service",
        "maze_localization",
        "maze_mapping",
        "maze_navigation",
        "maze_sim",
        "maze_sim_odometry",
        "real_robot",
        "real_robot_mapping",
        "real_robot_navigation",
        "real_robot_navigation_sim",
        "real_robot_sim",
    ]


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_bringups_resolve_against_the_install_layout_and_can_be_composed(name):
    bringup = load_bringup(name)
    assert bringup.source.parent.parts[-3:] == ("amr_bringup", "config", "bringup")
    assert bringup.source.read_text() == (ROOT / "config" / "bringup" / f"{name}.yaml").read_text()
    check_installed(bringup)
    check_composable(bringup)


def node(bringup, name):
    return next(n for n in bringup.nodes if n.name == name)


def test_maze_sim_starts_the_wall_follower_before_the_simulator():
    bringup = load_bringup("maze_sim")
    assert [n.name for n in bringup.nodes] == ["map_server", "simulator", "wall_follower"]
    assert bringup.node_startup_order == ("map_server", "wall_follower", "simulator")
    assert node(bringup, "wall_follower").parameter_files == ("wall_follower_sim.yaml",)


def test_maze_sim_odometry_routes_odom_through_the_odometry_node():
    from amr_simulation.simulator_node import NODE_PARAMETERS

    bringup = load_bringup("maze_sim_odometry")
    assert "publish_odometry" in NODE_PARAMETERS  # the simulator's real switch for /odometry
    assert node(bringup, "simulator").parameters["publish_odometry"] is False
    assert bringup.node_startup_order == ("map_server", "odometry_node", "wall_follower", "simulator")


@pytest.mark.parametrize("name", SHIPPED)
def test_simulated_stacks_run_on_sim_time_with_the_map_of_their_world_real_ones_on_the_wall_clock(name):
    """One time base: where a simulator publishes /clock every node follows it; a robot's stack keeps its clock."""
    bringup = load_bringup(name)
    simulated = any(n.executable == "simulator" for n in bringup.nodes)
    assert all(n.parameters.get("use_sim_time", False) is simulated for n in bringup.nodes), name
    if simulated and any(n.executable == "map_server" for n in bringup.nodes):  # mapping stacks build theirs
        assert node(bringup, "map_server").parameters["world"] == node(bringup, "simulator").parameters["world"]
        assert {("simulator", "world"), ("map_server", "world")} <= set(bringup.arguments["world"].sets)
        moved = bringup.with_overrides({"world": "hard_maze.yaml"})
        assert {n.parameters.get("world") for n in moved.nodes} - {None} == {"hard_maze.yaml"}


MAP_SOURCES = {"world", "map_yaml", "yaml_filename"}
"""Parameters through which a node loads a world or a map file itself."""
GEOMETRY_LOADERS = {"simulator", "map_server"}
"""The nodes that need the world's geometry: physics, and the stack's one map."""
ROBOT_LIST_READERS = {"fleet_planner"}
"""The nodes that read only the world's robots list (the fleet's names); their geometry comes from /map."""


@pytest.mark.parametrize("name", SHIPPED)
def test_every_stack_loads_its_world_once_per_node_that_needs_geometry(name):
    """The simulator (physics) and the map server (/map) load the world; the particle filter and the planner take
    /map, whatever their parameter files say; the fleet planner reads only its robots list; and the world argument
    changes every one of them at once."""
    from amr_util.parameter_file import dotted, node_parameters

    bringup = load_bringup(name)
    for spec in bringup.nodes:
        values = {}
        for path in spec.parameter_file_paths():
            values.update(dotted(node_parameters(path, spec.name)))
        values.update(spec.parameters)
        loaded = {key for key in MAP_SOURCES if values.get(key)}
        robot_map = "map" in bringup.arguments and not bringup.arguments["map"].clears  # no world: map:= only
        if spec.executable == "map_server" and robot_map:  # a robot's map: the `map` argument's
            assert not loaded and ("map_server", "yaml_filename") in bringup.arguments["map"].sets, name
        elif spec.executable in GEOMETRY_LOADERS | ROBOT_LIST_READERS:
            assert loaded == {"world"}, (name, spec.name, loaded)
        else:
            assert not loaded, f"{name}: {spec.name} loads {loaded} itself instead of taking /map"
    if "world" in bringup.arguments:
        loaders = {n.name for n in bringup.nodes if n.executable in GEOMETRY_LOADERS | ROBOT_LIST_READERS}
        assert {node for node, _ in bringup.arguments["world"].sets} == loaders


@pytest.mark.parametrize("name", ["maze_sim", "maze_localization", "maze_navigation"])
def test_a_per_node_world_is_refused_naming_the_world_argument(name):
    bringup = load_bringup(name)
    for target in ("simulator.world", "map_server.world"):
        with pytest.raises(
            BringupError,
            match=rf"-p {target}:=hard_maze.yaml: {target} is tied to .* by the stack "
            r"argument world:= \(they must agree\); give world:=hard_maze.yaml instead",
        ):
            bringup.with_overrides({}, {target: "hard_maze.yaml"})
    assert bringup.with_overrides({}, {"simulator.seed": "3"}).current_value("world") == bringup.current_value("world")
    if name != "maze_sim":  # one map for the stack: the resolution is the stack's too
        assert bringup.with_overrides({"map_resolution": "0.025"}).nodes[0].parameters["resolution"] == 0.025


def test_maze_navigation_has_one_driver_and_navigated_controllers():
    bringup = load_bringup("maze_navigation")
    assert node(bringup, "wall_follower").parameters["navigated"] is True
    assert node(bringup, "path_follower").parameters["navigated"] is True
    assert node(bringup, "simulator").parameters["stop_at_goal"] is False
    assert node(bringup, "navigator").parameters["world_goal_topic"] == "/simulator/goal"
    order = bringup.node_startup_order
    assert order.index("navigator") < order.index("particle_filter") < order.index("simulator")
    assert max(order.index(n) for n in ("planner", "path_follower", "wall_follower")) < order.index("navigator")


def test_real_robot_has_no_simulator_and_the_real_robot_config():
    bringup = load_bringup("real_robot")
    assert [n.name for n in bringup.nodes] == ["odometry_node", "wall_follower"]
    assert bringup.node_startup_order == ("odometry_node", "wall_follower")  # default: listed order
    assert node(bringup, "wall_follower").parameter_files == ("wall_follower_real.yaml",)


def test_ik_service_serves_the_packaged_chains():
    (ik,) = load_bringup("ik_service").nodes
    assert (ik.package, ik.executable, ik.parameter_files) == ("amr_kinematics", "ik_service", ("ik_chains.yaml",))


def test_node_classes_are_the_managed_nodes_the_executables_run():
    for (package, executable), (module, name) in NODE_CLASSES.items():
        cls = getattr(__import__(module, fromlist=[name]), name)
        assert issubclass(cls, ManagedNode)
        assert "kwargs" in inspect.signature(cls.__init__).parameters  # cli_args reaches rclpy
        wrapper = (Path(__file__).resolve().parents[2] / "resource" / "lib" / package / executable).read_text()
        assert f"-m {module} " in wrapper


def test_ros_arguments_give_name_namespace_files_parameters_and_remappings(tmp_path):
    params = tmp_path / "p.yaml"
    spec = NodeSpec(
        name="follower",
        package="amr_control",
        executable="wall_follower",
        namespace="/robot1",
        parameter_files=(str(params),),
        parameters={"kp": 4.0, "simulation": True, "preferred_wall": "left", "lidar.beams": 240, "window": [1.0, 2.5]},
        remappings=(("cmd_vel", "/robot1/cmd"),),
    )
    assert spec.ros_arguments() == [
        "--ros-args",
        "-r",
        "__node:=follower",
        "-r",
        "__ns:=/robot1",
        "--params-file",
        str(params),
        "-p",
        "kp:=4.0",
        "-p",
        "simulation:=true",
        "-p",
        'preferred_wall:="left"',
        "-p",
        "lidar.beams:=240",
        "-p",
        "window:=[1.0, 2.5]",
        "-r",
        "cmd_vel:=/robot1/cmd",
    ]
    assert spec.managed_name == "/robot1/follower"
    assert spec.launch_parameters() == [str(params), dict(spec.parameters)]


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (1.0, "1.0"),
        (2, "2"),
        (False, "false"),
        ("true", '"true"'),
        ("a b", '"a b"'),
        (float("inf"), ".inf"),
        (["x", "y"], '["x", "y"]'),
        ([True, False], "[true, false]"),
    ],
)
def test_inline_values_keep_their_type_through_the_command_line(value, text):
    assert yaml_scalar(value) == text
    assert yaml.safe_load(text) == value  # rcl reads -p values as YAML


def test_nested_inline_parameters_become_dotted_names(tmp_path):
    bringup = parse_bringup(
        {
            "nodes": [
                {
                    "name": "simulator",
                    "package": "amr_simulation",
                    "executable": "simulator",
                    "parameters": {"lidar": {"beams": 90, "noise_std": 0.0}},
                }
            ]
        },
        tmp_path / "b.yaml",
    )
    assert bringup.nodes[0].parameters == {"lidar.beams": 90, "lidar.noise_std": 0.0}


def test_namespaces_are_made_absolute(tmp_path):
    bringup = parse_bringup(
        {"nodes": [{"name": "a", "package": "p", "executable": "e", "namespace": "fleet/r1/"}]}, tmp_path / "b.yaml"
    )
    assert bringup.nodes[0].namespace == "/fleet/r1"
    assert bringup.node_startup_order == ("/fleet/r1/a",)


GOOD = {"name": "a", "package": "amr_control", "executable": "wall_follower"}


@pytest.mark.parametrize(
    ("document", "key"),
    [
        ([1, 2], "must be a mapping"),
        ({"nodes": []}, "nodes: must be a non-empty list"),
        ({"nodes": [GOOD], "launch": 1}, "unknown key(s) ['launch']"),
        ({"nodes": [{**GOOD, "params": {}}]}, "nodes[0]: unknown key(s) ['params']"),
        ({"nodes": ["a"]}, "nodes[0]: must be a mapping"),
        ({"nodes": [{"name": "a", "executable": "e"}]}, "nodes[0].package: must be a name"),
        ({"nodes": [{**GOOD, "name": "wall follower"}]}, "nodes[0].name: must be a name"),
        ({"nodes": [{**GOOD, "namespace": "/9robots"}]}, "nodes[0].namespace:"),
        ({"nodes": [GOOD, GOOD]}, "nodes[1].name: 'a' is also nodes[0]"),
        ({"nodes": [{**GOOD, "parameter_files": "x.yaml"}]}, "nodes[0].parameter_files: must be a list"),
        ({"nodes": [{**GOOD, "parameters": [1]}]}, "nodes[0].parameters: must be a mapping"),
        ({"nodes": [{**GOOD, "parameters": {"gains": [1, 2.5]}}]}, "nodes[0].parameters.gains: a list parameter"),
        ({"nodes": [{**GOOD, "parameters": {"gains": []}}]}, "nodes[0].parameters.gains: a list parameter"),
        ({"nodes": [{**GOOD, "parameters": {"x": None}}]}, "nodes[0].parameters.x: unsupported value"),
        ({"nodes": [{**GOOD, "remappings": {"cmd vel": "x"}}]}, "nodes[0].remappings: 'cmd vel'"),
        ({"nodes": [GOOD], "lifecycle_manager": [1]}, "lifecycle_manager: must be a mapping"),
        (
            {"nodes": [GOOD], "lifecycle_manager": {"autostart": True}},
            "lifecycle_manager: unknown key(s) ['autostart']",
        ),
        (
            {"nodes": [GOOD], "lifecycle_manager": {"node_startup_order": ["b"]}},
            "lifecycle_manager.node_startup_order: 'b' is not one of the nodes ['a']",
        ),
        (
            {"nodes": [GOOD], "lifecycle_manager": {"node_startup_order": ["a", "a"]}},
            "lifecycle_manager.node_startup_order: names a node twice",
        ),
        (
            {"nodes": [GOOD], "lifecycle_manager": {"wait_timeout": -1}},
            "lifecycle_manager.wait_timeout: must be in [0.1, 3600], got -1.0",
        ),
    ],
)
def test_errors_name_the_file_and_the_key(document, key, tmp_path):
    source = tmp_path / "stack.yaml"
    with pytest.raises(BringupError) as caught:
        parse_bringup(document, source)
    message = str(caught.value)
    assert message.startswith(f"{source}: ") and key in message, message


def test_manager_timeouts_and_order_reach_the_manager_parameters(tmp_path):
    bringup = parse_bringup(
        {
            "nodes": [GOOD, {**GOOD, "name": "b"}],
            "lifecycle_manager": {"node_startup_order": ["b", "a"], "wait_timeout": 5},
        },
        tmp_path / "b.yaml",
    )
    assert bringup.manager_parameters() == {"node_startup_order": ["b", "a"], "wait_timeout": 5.0}


def test_invalid_yaml_names_the_file(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("nodes: [\n")
    with pytest.raises(BringupError, match="broken.yaml: not valid YAML"):
        load_bringup(path)


def test_a_bare_name_finds_the_shipped_file_and_an_unknown_one_lists_them(tmp_path):
    assert find_bringup("real_robot") == find_bringup("real_robot.yaml")
    with pytest.raises(
        BringupError,
        match="shipped: fleet_navigation, fleet_sim, ik_service, maze_localization, maze_mapping, maze_navigation, "
        "maze_sim, maze_sim_odometry, real_robot",
    ):
        find_bringup("maze")
    own = tmp_path / "mine.yaml"
    own.write_text(yaml.safe_dump({"nodes": [GOOD]}))
    assert load_bringup(str(own)).nodes[0].name == "a"
    with pytest.raises(BringupError, match="no such file"):
        find_bringup(str(tmp_path / "absent.yaml"))


@pytest.mark.parametrize(
    ("entry", "key"),
    [
        ({"package": "no_such_package", "executable": "x"}, "nodes[0].package: a: package 'no_such_package'"),
        ({"package": "amr_control", "executable": "no_such_node"}, "nodes[0].executable: a: "),
        (
            {"package": "amr_control", "executable": "wall_follower", "parameter_files": ["absent.yaml"]},
            "nodes[0].parameter_files[0]: a: ",
        ),
    ],
)
def test_check_installed_names_what_is_missing(entry, key, tmp_path):
    bringup = parse_bringup({"nodes": [{"name": "a", **entry}]}, tmp_path / "b.yaml")
    with pytest.raises(BringupError) as caught:
        check_installed(bringup)
    assert key in str(caught.value)


def test_absolute_parameter_files_are_taken_as_they_are(tmp_path):
    params = tmp_path / "mine.yaml"
    params.write_text("wall_follower:\n  ros__parameters:\n    kp: 1.0\n")
    bringup = parse_bringup({"nodes": [{**GOOD, "parameter_files": [str(params)]}]}, tmp_path / "b.yaml")
    assert bringup.nodes[0].parameter_file_paths() == [params]
    check_installed(bringup)


def test_composed_mode_refuses_a_node_it_has_no_class_for(tmp_path):
    bringup = parse_bringup(
        {"nodes": [{"name": "a", "package": "amr_bringup", "executable": "lifecycle_manager"}]}, tmp_path / "b.yaml"
    )
    with pytest.raises(BringupError, match=r"nodes\[0\].executable: amr_bringup/lifecycle_manager has no node class"):
        check_composable(bringup)


def test_arguments_and_parameters_override_the_stack_and_unknown_names_are_refused():
    bringup = load_bringup("maze_sim")
    assert {
        "world",
        "start",
        "preferred_wall",
        "mode",
        "use_sim_time",
        "simulator_params_file",
        "wall_follower_params_file",
    } <= set(bringup.arguments)
    assert bringup.current_value("world") == "outer_corridor.yaml"
    changed = bringup.with_overrides(
        {"world": "hard_maze.yaml", "start": "[0.5, -1.0, 1.57]", "use_sim_time": "true"}, {"wall_follower.kp": "3.0"}
    )
    _, simulator, follower = changed.nodes
    assert simulator.parameters == {"world": "hard_maze.yaml", "start": [0.5, -1.0, 1.57], "use_sim_time": True}
    assert follower.parameters == {"use_sim_time": True, "kp": 3.0}
    assert "-p" in simulator.ros_arguments() and 'world:="hard_maze.yaml"' in simulator.ros_arguments()
    replaced = bringup.with_overrides({"wall_follower_params_file": "/tmp/mine.yaml"})
    assert replaced.nodes[2].parameter_files == ("/tmp/mine.yaml",)
    assert "start" not in bringup.with_overrides({"start": "[]"}).nodes[1].parameters, "[] keeps the world's start"
    with pytest.raises(
        BringupError, match=r"unknown argument 'wrld' \(known: map_server_params_file, mode, preferred_wall"
    ):
        bringup.with_overrides({"wrld": "x"})
    with pytest.raises(BringupError, match=r"-p simulatr.world: expected <node>.<parameter>:=<value> with a node"):
        bringup.with_overrides({}, {"simulatr.world": "x"})


def test_bad_argument_sections_are_refused_naming_the_key(tmp_path):
    document = {"nodes": [GOOD], "arguments": {"gain": {"sets": ["b.kp"]}}}
    with pytest.raises(BringupError, match=r"arguments.gain.sets: 'b.kp' is not <node>.<parameter>"):
        parse_bringup(document, tmp_path / "s.yaml")
    with pytest.raises(BringupError, match=r"arguments.gain: unknown key"):
        parse_bringup({"nodes": [GOOD], "arguments": {"gain": {"sets": ["a.kp"], "default": 1}}}, tmp_path / "s.yaml")


def test_help_lists_every_shipped_stack_with_its_summary(capsys):
    from amr_bringup.bringup import parse_arguments

    with pytest.raises(SystemExit) as exit:
        parse_arguments(["--help"])
    assert exit.value.code == 0
    shown = capsys.readouterr().out.split("shipped stacks")[1]
    stacks = sorted(path.stem for path in (ROOT / "config" / "bringup").glob("*.yaml"))
    assert "maze_navigation" in stacks
    listed = [line.split()[0] for line in shown.splitlines()[1:] if line.strip()]
    assert listed == stacks
    assert "maze_navigation Explore, localize, plan, go" in " ".join(shown.split())  # names padded to the longest
