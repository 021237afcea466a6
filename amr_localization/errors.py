"""Exceptions of the localization library: ValueErrors whose message names what is wrong.

The node shells tell the kinds apart by type, never by text: an odometry pose that cannot be used
means the last estimate is repeated; a scan or a beacon reading that cannot be used means the update
goes on without it.
"""


class LocalizationError(ValueError):
    """Input the localizers refuse: a map without free space, a malformed scan, an empty beacon list, ..."""


class OdometryError(LocalizationError):
    """An odometry pose that cannot be used (not three finite numbers): the update cannot move the estimate."""


class ScanError(LocalizationError):
    """A scan that cannot be used (ranges not numbers, a bad angle or range field)."""


class BeaconError(LocalizationError):
    """A beacon reading that cannot be used (ranges not finite or negative, another count or other positions)."""
