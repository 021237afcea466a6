"""Build the suite's rosidl packages with CMake and install them into this Python's prefix.

amr_interfaces always; interfaces/tf2_msgs (tf2_msgs/msg/TFMessage as Jazzy defines it, for /tf)
only where no other tf2_msgs is installed: a ROS 2 Jazzy install on AMENT_PREFIX_PATH keeps its own.
Run with the venv's Python. It is incremental: a package's build is skipped when its
interface files, CMakeLists.txt and package.xml hash to what was last installed.
Two fixes make the ros-jazzy-* wheels build here: the wheels' exported CMake
files name the wheel builder's include directories (/opt/python/cp311-cp311/...),
which we rewrite to this interpreter's; and configure needs AMENT_PREFIX_PATH.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

import numpy

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = {"amr_interfaces": ROOT / "amr_interfaces", "tf2_msgs": ROOT / "interfaces" / "tf2_msgs"}
BUILT_ONLY_WHERE_MISSING = ("tf2_msgs",)
PREFIX = Path(sys.prefix)
WHEEL_BUILDER_PYTHON = "/opt/python/cp311-cp311/include/python3.11"
WHEEL_BUILDER_NUMPY = "/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include"


def stamp(package: str) -> Path:
    return PREFIX / "share" / package / ".source_hash"


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
            path.write_text(new_text)
            changed += 1
    return changed


def child_environment() -> dict[str, str]:
    """The environment for cmake: ROS prefix set, the bootstrapper's markers cleared."""
    env = {k: v for k, v in os.environ.items() if k not in ("_ROS_WHEELS_BOOTSTRAP_COMPLETE",)}
    env["AMENT_PREFIX_PATH"] = str(PREFIX)
    env["CMAKE_PREFIX_PATH"] = str(PREFIX)
    env["LD_LIBRARY_PATH"] = os.pathsep.join(
        p for p in (str(PREFIX / "lib"), os.environ.get("LD_LIBRARY_PATH", "")) if p
    )
    return env


def run(command: list[str], env: dict[str, str]) -> None:
    result = subprocess.run(command, env=env, capture_output=True, text=True)
    if result.returncode != 0:
        sys.stderr.write(result.stdout[-4000:] + result.stderr[-4000:])
        raise SystemExit(f"build_interfaces: `{' '.join(command[:3])} ...` failed ({result.returncode})")


def build(source: Path, build_dir: Path) -> None:
    env = child_environment()
    build_dir.mkdir(parents=True, exist_ok=True)
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
            "-DCMAKE_BUILD_TYPE=Release",
        ],
        env,
    )
    run(["cmake", "--build", str(build_dir), "--parallel", str(os.cpu_count() or 2)], env)
    run(["cmake", "--install", str(build_dir)], env)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="rebuild even if nothing changed")
    parser.add_argument("--build-dir", type=Path, default=Path("build"), help="one subdirectory per package")
    args = parser.parse_args()

    fixed = False
    for package, source in PACKAGES.items():
        if package in BUILT_ONLY_WHERE_MISSING and (elsewhere := installed_elsewhere(package)):
            print(f"{package}: provided by {elsewhere}, not built")
            continue
        wanted = source_hash(source)
        if not args.force and stamp(package).is_file() and stamp(package).read_text().strip() == wanted:
            print(f"{package}: up to date")
            continue
        started = time.monotonic()
        changed = 0 if fixed else rewrite_exported_include_paths()
        fixed = True
        build(source, (args.build_dir / package).resolve())
        stamp(package).write_text(wanted + "\n")
        print(
            f"{package}: built and installed into {PREFIX} in {time.monotonic() - started:.1f} s"
            f" ({changed} exported CMake files fixed)"
        )


if __name__ == "__main__":
    main()
