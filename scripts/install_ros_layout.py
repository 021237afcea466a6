"""Install the ROS 2 layout (ament index, package.xml, config, lib/<pkg>/<exe>) into this prefix.

`pip install .` installs these data files itself; an editable install (`pip install -e .`,
what the Makefile does for development) does not, so this copies the same table,
[tool.setuptools.data-files] in pyproject.toml, into sys.prefix. One table, two paths.

In a venv it also makes activation set the ROS environment: resource/env/setup.bash goes to the
prefix (AMENT_PREFIX_PATH, ROS_DISTRO, ...), and bin/activate sources it. Only in a venv: in a
colcon install space that name is colcon's own.
"""

from __future__ import annotations

import shutil
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    table = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["data-files"]
    copied = 0
    for destination, patterns in table.items():
        target_dir = Path(sys.prefix) / destination
        target_dir.mkdir(parents=True, exist_ok=True)
        for pattern in patterns:
            sources = sorted(ROOT.glob(pattern))
            if not sources:
                raise SystemExit(f"install_ros_layout: pattern {pattern!r} ({destination}) matches no file")
            for source in sources:
                if source.is_file():
                    shutil.copy2(source, target_dir / source.name)
                    copied += 1
    print(f"ROS layout: {copied} files installed under {sys.prefix}")
    if sys.prefix != sys.base_prefix:
        shutil.copy2(ROOT / "resource" / "env" / "setup.bash", Path(sys.prefix) / "setup.bash")
        hook_activation(Path(sys.prefix) / "bin" / "activate")


ACTIVATION_HOOK = '. "$VIRTUAL_ENV/setup.bash"  # the ROS environment (amr_suite scripts/install_ros_layout.py)\n'


def hook_activation(activate: Path) -> None:
    """Append the sourcing of setup.bash to the venv's activate script, once."""
    text = activate.read_text()
    if ACTIVATION_HOOK not in text:
        activate.write_text(text + ("" if text.endswith("\n") else "\n") + ACTIVATION_HOOK)


if __name__ == "__main__":
    main()
