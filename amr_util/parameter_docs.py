"""Parameter tables for the docs, written from the specs (no rclpy): what each parameter is, in Markdown.

A docs page holds one generated block per node between two markers,

    <!-- parameters: amr_control/wall_follower -->
    | parameter | type | default | ... |
    <!-- end parameters -->

and `splice` rewrites the blocks from the specs. The registry of nodes (which specs, which shipped
parameter files) lives with the packages on top (`python -m amr_bringup.parameter_docs`); a test fails
when a committed table differs from what the specs give, so the docs cannot drift from the code.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

from amr_util.parameter_spec import ParameterSpec

BEGIN = "<!-- parameters: {key} -->"
END = "<!-- end parameters -->"
BLOCK = re.compile(r"<!-- parameters: (?P<key>[\w./-]+) -->\n(?P<body>.*?)<!-- end parameters -->", re.S)
KIND_NAMES = {
    "bool": "bool",
    "int": "int",
    "float": "float",
    "str": "string",
    "bool_array": "bool[]",
    "int_array": "int[]",
    "float_array": "float[]",
    "str_array": "string[]",
}


def value_text(value: Any) -> str:
    """A parameter value as YAML writes it (true, 0.05, '', [a, b]), short."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):  # always with a point: YAML (and rclpy) read 4 as an integer, 4.0 as a float
        text = f"{value:.6g}" if math.isfinite(value) else str(value)
        return text if any(c in text for c in ".en") else text + ".0"
    if isinstance(value, str):
        return value if value else "''"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(value_text(item) for item in value) + "]"
    return str(value)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _code(value: Any) -> str:
    return f"`{value_text(value)}`"


def _when(spec: ParameterSpec) -> str:
    if spec.read_only:
        return "read-only"
    return "live" if spec.live else "structural"


def _limits(spec: ParameterSpec) -> str:
    text = spec.range_text.removeprefix("in ")
    if spec.choices:
        text = (text + "; " if text else "") + ", ".join(f"`{choice}`" for choice in spec.choices)
    return text


def parameter_table(specs: Sequence[ParameterSpec], files: Mapping[str, Mapping[str, Any]] | None = None) -> str:
    """A Markdown table, one row per spec: name, type, default, limits, live/structural, description, and
    one column per shipped parameter file (`files`: {file name: {parameter: value}}; blank = not set)."""
    files = files or {}
    header = ["parameter", "type", "default", *(f"`{name}`" for name in files), "range", "when", "description"]
    rows = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for spec in specs:
        in_files = [_code(values[spec.name]) if spec.name in values else "" for values in files.values()]
        cells = [
            f"`{spec.name}`",
            KIND_NAMES[spec.kind],
            _code(spec.default),
            *in_files,
            _limits(spec),
            _when(spec),
            spec.description,
        ]
        rows.append("| " + " | ".join(_cell(cell) for cell in cells) + " |")
    return "\n".join(rows) + "\n"


def blocks(text: str) -> dict[str, str]:
    """{key: body} of the generated blocks of a docs page."""
    return {match["key"]: match["body"] for match in BLOCK.finditer(text)}


def splice(text: str, tables: Mapping[str, str]) -> tuple[str, list[str]]:
    """The page with every block whose key `tables` has rewritten; and the keys found without a table."""
    missing: list[str] = []

    def replace(match: re.Match) -> str:
        key = match["key"]
        if key not in tables:
            missing.append(key)
            return match[0]
        return f"{BEGIN.format(key=key)}\n{tables[key]}{END}"

    return BLOCK.sub(replace, text), missing


def drift(text: str, tables: Mapping[str, str]) -> list[str]:
    """The keys whose block in `text` differs from the table the specs give (and blocks without a table)."""
    found = blocks(text)
    return sorted(key for key, body in found.items() if tables.get(key) != body)
