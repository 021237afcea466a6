"""Where a package's installed files are: its prefix and share/<package>, from the ament index or this prefix.

The one lookup every package uses. A venv used without a sourced ROS environment (AMENT_PREFIX_PATH
unset) still finds what `make setup` or `pip install` put under this Python's prefix.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ament_index_python.packages import PackageNotFoundError, get_package_prefix


def package_prefix(package: str) -> Path:
    """The install prefix of `package`: the ament index's answer, else this Python's prefix if its index lists it;
    PackageNotFoundError otherwise."""
    try:
        return Path(get_package_prefix(package))
    except (PackageNotFoundError, OSError):  # OSError: AMENT_PREFIX_PATH is not set
        if (Path(sys.prefix) / "share" / "ament_index" / "resource_index" / "packages" / package).is_file():
            return Path(sys.prefix)
        raise PackageNotFoundError(f"package {package!r} not found in the ament index nor under {sys.prefix}") from None


def share_directory(package: str, must_exist: bool = False) -> Path:
    """share/<package> under package_prefix(package); where no index lists the package, share/<package> under
    this Python's prefix, or PackageNotFoundError with must_exist."""
    try:
        return package_prefix(package) / "share" / package
    except PackageNotFoundError:
        if must_exist:
            raise
        return Path(sys.prefix) / "share" / package
