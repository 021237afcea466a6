"""The parallel run's file order (support.schedule): longest first, each file's tests together and in their order."""

from __future__ import annotations

from types import SimpleNamespace

from support.schedule import SECONDS, TESTS, longest_files_first, seconds_per_file


def items(*nodeids: str) -> list:
    return [SimpleNamespace(path=TESTS / nodeid.split("::")[0], nodeid=nodeid) for nodeid in nodeids]


def test_every_file_the_table_names_exists():
    missing = [name for name in SECONDS if not (TESTS / name).is_file()]
    assert not missing, f"support/schedule.py SECONDS names files that are gone: {missing}"


def test_longest_file_first_its_tests_together_and_in_order_unknown_files_keep_their_place():
    collected = items(
        "maps/test_a.py::one",
        "foundation/test_colcon_build.py::build",
        "maps/test_a.py::two",
        "viewer/test_browser.py::page",
        "maps/test_b.py::one",
        "viewer/test_browser.py::scene",
    )
    ordered = [item.nodeid for item in longest_files_first(collected)]
    assert ordered == [
        "viewer/test_browser.py::page",
        "viewer/test_browser.py::scene",
        "foundation/test_colcon_build.py::build",
        "maps/test_a.py::one",
        "maps/test_a.py::two",
        "maps/test_b.py::one",
    ]


def test_durations_are_summed_per_file_longest_first():
    lines = [
        "============ slowest durations ============",
        "12.50s call     tests/bringup/test_demo.py::test_demo_writes_figures",
        "3.00s setup    tests/viewer/test_browser.py::test_page[chromium]",
        "20.00s call     tests/viewer/test_browser.py::test_scene",
        "0.50s teardown tests/bringup/test_demo.py::test_demo_writes_figures",
        "1.50s cpu tests/bringup/test_demo.py::test_demo_writes_figures",  # AMR_TEST_CPU's lines
        "(12 durations < 0.005s hidden.)",
    ]
    assert seconds_per_file(lines) == {"viewer/test_browser.py": 23.0, "bringup/test_demo.py": 14.5}
