"""amr-bringup --view: its options, a port in use refused before anything starts, the viewer's command line."""

import socket

import pytest

from amr_bringup.bringup import main, parse_arguments
from amr_bringup.viewing import port_problem, viewer_command, viewer_url


def test_view_options_default_to_localhost_8080():
    options = parse_arguments(["maze_sim"])
    assert (options.view, options.view_host, options.view_port) == (False, "127.0.0.1", 8080)


@pytest.mark.parametrize(
    "argv,problem",
    [
        (["maze_sim", "--view-port", "9000"], "--view-port and --view-host need --view"),
        (["maze_sim", "--view-host", "0.0.0.0"], "--view-port and --view-host need --view"),
        (["maze_sim", "--view", "--view-port", "70000"], "--view-port must be in 1..65535"),
    ],
)
def test_bad_view_options_are_refused(argv, problem, capsys):
    with pytest.raises(SystemExit) as exit_:
        parse_arguments(argv)
    assert exit_.value.code == 2 and problem in capsys.readouterr().err


def test_a_port_in_use_is_refused_before_the_stack_starts(capsys):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert "cannot serve on 127.0.0.1:" in port_problem("127.0.0.1", port)
        assert main(["maze_sim", "--view", "--view-port", str(port)]) == 2
    error = capsys.readouterr().err
    assert f"--view: cannot serve on 127.0.0.1:{port}" in error and "choose another with --view-port" in error


def test_the_viewer_runs_on_the_stacks_time_and_prints_a_reachable_url():
    command = viewer_command("viewer_maze_sim", "0.0.0.0", 8123, simulated=True)
    assert command[0].endswith("lib/amr_viewer/viewer")
    assert command[1:] == [
        "--ros-args",
        "-r",
        "__node:=viewer_maze_sim",
        "-p",
        "autostart:=true",
        "-p",
        "host:=0.0.0.0",
        "-p",
        "port:=8123",
        "-p",
        "use_sim_time:=true",
    ]
    assert viewer_url("0.0.0.0", 8123) == "http://127.0.0.1:8123"
    assert viewer_url("::1", 8123) == "http://[::1]:8123"
