"""Where a package's installed files are: share/<package> from the ament index or this prefix."""

from __future__ import annotations

import sys
from pathlib import Path

from ament_index_python.packages import PackageNotFoundError, get_package_share_directory


def share_directory(package: str) -> Path:
    """share/<package> from the ament index, or under this Python's prefix in a venv with no ROS sourced."""
    try:
        return Path(get_package_share_directory(package))
    except (PackageNotFoundError, OSError):
        return Path(sys.prefix) / "share" / package
