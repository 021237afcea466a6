"""Parameter tables from specs, and telling a committed table that drifted from one that did not."""

from amr_util.parameter_docs import drift, parameter_table, splice, value_text
from amr_util.parameter_spec import ParameterSpec

SPECS = (
    ParameterSpec("kp", 4.0, "rad/s per m | gain", minimum=0.0, maximum=100.0, live=True),
    ParameterSpec("wall", "right", "hand", choices=("right", "left")),
    ParameterSpec("topics", [""], "to record", kind="str_array", read_only=True),
)


def test_a_table_has_one_row_per_parameter_with_file_columns():
    table = parameter_table(SPECS, {"real.yaml": {"kp": 7.6}})
    rows = table.splitlines()
    assert rows[0] == "| parameter | type | default | `real.yaml` | range | when | description |"
    assert rows[2] == "| `kp` | float | `4.0` | `7.6` | [0, 100] | live | rad/s per m \\| gain |"
    assert rows[3] == "| `wall` | string | `right` |  | `right`, `left` | structural | hand |"
    assert rows[4] == "| `topics` | string[] | `['']` |  |  | read-only | to record |"


def test_values_read_as_yaml_types():
    assert [value_text(v) for v in (True, 4.0, 1e-5, 10, "", [0.0, 1.5])] == [
        "true",
        "4.0",
        "1e-05",
        "10",
        "''",
        "[0.0, 1.5]",
    ]


def test_a_block_is_rewritten_and_drift_is_found():
    page = "intro\n<!-- parameters: pkg/node -->\nold table\n<!-- end parameters -->\nmore\n"
    tables = {"pkg/node": parameter_table(SPECS)}
    assert drift(page, tables) == ["pkg/node"]
    new, missing = splice(page, tables)
    assert missing == [] and drift(new, tables) == [] and new.startswith("intro\n") and new.endswith("more\n")
    assert splice(page, {})[1] == ["pkg/node"]
