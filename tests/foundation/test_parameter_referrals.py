"""A group of parameters another table lists is one row linking there, and only while the specs are the same."""

from __future__ import annotations

import dataclasses

from support.doc_commands import parameter_docs


def node(key: str):
    return next(node for node in parameter_docs.NODES if node.key == key)


def test_the_navigators_traffic_rules_are_one_row_linking_to_the_traffic_table():
    table = parameter_docs.table(node("amr_navigation/navigator"))
    assert "`traffic_rules.map_tolerance`" not in table and "`costmap.safety_margin`" in table
    row = next(line for line in table.splitlines() if line.startswith("| `traffic_rules.*` |"))
    assert "[amr_navigation/traffic](#traffic-through-ros-the-navigator-node)" in row
    assert row.count("|") == table.splitlines()[0].count("|")  # as many cells as the header


def test_a_group_whose_specs_differ_from_the_target_is_refused():
    refer = parameter_docs.Refer("costmap.", "amr_navigation/traffic")  # the navigator's costmap is not traffic's
    wrong = dataclasses.replace(node("amr_navigation/navigator"), refers=(refer,))
    assert parameter_docs.referral_problems(wrong) == [
        "amr_navigation/navigator: costmap.* are not the * parameters of amr_navigation/traffic"
    ]
    assert parameter_docs.referral_problems(node("amr_navigation/navigator")) == []
    assert parameter_docs.referral_problems(node("amr_navigation/fleet_planner")) == []
