"""Exceptions of the localization library: ValueErrors whose message names what is wrong."""


class LocalizationError(ValueError):
    """Input the localizers refuse: a map without free space, a malformed scan, an empty beacon list, ..."""
