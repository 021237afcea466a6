"""Build the amr_interfaces rosidl package with CMake and install it into this Python's prefix.

Run with the venv's Python. It is incremental: the build is skipped when the
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

SOURCE = Path(__file__).resolve().parent.parent / "amr_interfaces"
PREFIX = Path(sys.prefix)
STAMP = PREFIX / "share" / "amr_interfaces" / ".source_hash"
WHEEL_BUILDER_PYTHON = "/opt/python/cp311-cp311/include/python3.11"
WHEEL_BUILDER_NUMPY = "/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include"


def source_hash() -> str:
    digest = hashlib.sha256()
    files = [SOURCE / "CMakeLists.txt", SOURCE / "package.xml"]
    files += sorted(SOURCE.glob("msg/*.msg")) + sorted(SOURCE.glob("srv/*.srv"))
    for path in files:
        digest.update(path.relative_to(SOURCE).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


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


def build(build_dir: Path) -> None:
    env = child_environment()
    build_dir.mkdir(parents=True, exist_ok=True)
    run(
        [
            "cmake", "-S", str(SOURCE), "-B", str(build_dir),
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
    parser.add_argument("--build-dir", type=Path, default=Path("build") / "amr_interfaces")
    args = parser.parse_args()

    wanted = source_hash()
    if not args.force and STAMP.is_file() and STAMP.read_text().strip() == wanted:
        print("amr_interfaces: up to date")
        return
    started = time.monotonic()
    changed = rewrite_exported_include_paths()
    build(args.build_dir.resolve())
    STAMP.write_text(wanted + "\n")
    print(f"amr_interfaces: built and installed into {PREFIX} in {time.monotonic() - started:.1f} s"
          f" ({changed} exported CMake files fixed)")


if __name__ == "__main__":
    main()
