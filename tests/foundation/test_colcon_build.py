"""A ROS user's path: colcon (from PyPI) builds the repository in a scratch workspace.

The interfaces are built as `make setup` builds them (scripts/build_interfaces.py): only what a Python node loads
(scripts/python_only_interfaces.cmake, through colcon's --cmake-args). The C++ headers and typesupports are rosidl's
own generators run on the same rosidl_generate_interfaces() call; they are half the build's CPU (79 s of it on two
cores, against 41 s) and no Python node loads them. `scripts/build_interfaces.py --all-typesupports` builds them.
The compiles go through ccache as `make setup`'s do (build_interfaces.compiler_cache, its cache in the repository's
build/): the same generated sources, so the objects come from setup's build; the generators, CMake, colcon, the link
and the install run here as in any workspace."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

from support.ros import ROOT
from support.scripts import load_script

from amr_util.environment import child_environment

PREFIX = Path(sys.prefix)


def tracked_files() -> list[str]:
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return [name for name in listed if (ROOT / name).is_file()]


def test_colcon_builds_interfaces_and_python_packages(tmp_path):
    workspace = tmp_path / "ws"
    for name in tracked_files():
        (workspace / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, workspace / name)
    cached, cache_env = load_script("build_interfaces").compiler_cache(workspace / "build", ROOT / "build" / "ccache")
    env = child_environment(
        AMENT_PREFIX_PATH=str(PREFIX),
        CMAKE_PREFIX_PATH=str(PREFIX),
        PATH=f"{PREFIX / 'bin'}{os.pathsep}{os.environ['PATH']}",
        PYTHONHASHSEED="0",  # the generators' output reproducible, as setup's (scripts/build_interfaces.py)
        **cache_env,
    )
    # the repository is itself a package, so colcon does not descend into it: name both base paths
    build = subprocess.run(
        [
            str(PREFIX / "bin" / "colcon"),
            "build",
            "--base-paths",
            ".",
            "amr_interfaces",
            "--cmake-args",
            "-DBUILD_TESTING=OFF",
            f"-DCMAKE_PROJECT_INCLUDE={workspace / 'scripts' / 'python_only_interfaces.cmake'}",
            "-DCMAKE_BUILD_TYPE=None",
            *cached,
        ],
        cwd=workspace,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]

    install = workspace / "install"
    for package, executable in [
        ("amr_turtlebot3", "odometry_node"),
        ("amr_kinematics", "ik_service"),
        ("amr_maps", "maze"),
    ]:
        assert os.access(install / "amr_suite" / "lib" / package / executable, os.X_OK)
    for package in sorted(p.parent.name for p in (ROOT / "resource").glob("*/package.xml")):
        assert (install / "amr_suite" / "share" / "ament_index" / "resource_index" / "packages" / package).is_file()
        assert (install / "amr_suite" / "share" / package / "package.xml").is_file()
    assert (install / "amr_suite" / "share" / "amr_maps" / "config" / "worlds" / "inner_maze.yaml").is_file()

    # what `source install/setup.sh` gives: the colcon-built interfaces import and the odometry module runs
    site = f"lib/python{sys.version_info.major}.{sys.version_info.minor}/site-packages"
    env["PYTHONPATH"] = os.pathsep.join(str(install / pkg / site) for pkg in ("amr_interfaces", "amr_suite"))
    env["LD_LIBRARY_PATH"] = f"{install / 'amr_interfaces' / 'lib'}{os.pathsep}{PREFIX / 'lib'}"
    env["_ROS_WHEELS_BOOTSTRAP_COMPLETE"] = "1"
    probe = subprocess.run(
        [
            sys.executable,
            "-c",
            "import amr_interfaces.srv as s, amr_turtlebot3.odometry as o, amr_kinematics.solvers.dls, "
            "amr_maps.maze_command, amr_evaluation.closed_loop; "
            "print(s.SolveIK.__module__, s.SolveIK.Request().__class__.__name__, o.__file__)",
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert probe.returncode == 0, probe.stderr
    assert str(install) in probe.stdout and "SolveIK_Request" in probe.stdout
