"""The parallel run's file order (support.schedule): longest first, each file's tests together and in their order."""

from __future__ import annotations

import ast
from types import SimpleNamespace

from support import numba_cache
from support.schedule import (
    SECONDS,
    TESTS,
    WITHOUT_KERNELS,
    calls_no_kernel,
    longest_files_first,
    seconds_per_file,
    timeline,
    walls_per_file,
)


def items(*nodeids: str) -> list:
    return [
        SimpleNamespace(path=TESTS / nodeid.split("::")[0], nodeid=nodeid, name=nodeid.partition("::")[2])
        for nodeid in nodeids
    ]


def test_every_file_the_table_names_exists():
    missing = [name for name in SECONDS if not (TESTS / name).is_file()]
    assert not missing, f"support/schedule.py SECONDS names files that are gone: {missing}"


def test_every_test_said_to_call_no_kernel_exists():
    for entry in WITHOUT_KERNELS:
        name, _, test = entry.partition("::")
        assert (TESTS / name).is_file(), f"support/schedule.py WITHOUT_KERNELS: no {name}"
        if test:
            tree = ast.parse((TESTS / name).read_text(encoding="utf-8"))
            found = [node.name for node in tree.body if isinstance(node, ast.FunctionDef)]
            assert any(function.startswith(test) for function in found), f"WITHOUT_KERNELS: no test {entry}"


def test_a_test_calls_no_kernel_only_when_named_or_in_a_file_named():
    colcon, webgl, scene, other = items(
        "foundation/test_colcon_build.py::test_colcon_builds",
        "viewer/test_browser.py::test_a_page_without_webgl_says_so",
        "viewer/test_browser.py::test_the_scene_is_drawn",
        "maps/test_a.py::test_a_page_without_webgl",
    )
    assert calls_no_kernel(colcon) and calls_no_kernel(webgl)
    assert not calls_no_kernel(scene) and not calls_no_kernel(other)


def test_a_warm_up_whose_part_fails_still_ends_and_says_so(tmp_path, monkeypatch):
    """The marker the workers wait for is written however the warm-up ends (here a part the child does not know)."""
    monkeypatch.setattr(numba_cache, "PROCESSES", (("no-such-part",),))
    done = tmp_path / "done"
    warming = numba_cache.Warming(done, timeout=60.0)
    assert numba_cache.wait_for(done, timeout=60.0) < 60.0 and done.is_file()
    assert "not compiled ahead: no-such-part" in warming.line(timeout=10.0)


def test_the_timeline_gives_the_warm_up_each_worker_and_the_files_that_ended_last():
    record = [
        "# warm-up 100.00 130.00",
        "# collected gw0 110.00",
        "# collected gw1 111.00",
        "# waited gw0 113.00 130.00",
        "5.00s cpu tests/viewer/test_browser.py::test_webgl gw0 111.00 113.00",
        "60.00s cpu tests/foundation/test_colcon_build.py::test_build gw1 111.50 200.00",
        "9.00s cpu tests/viewer/test_browser.py::test_scene gw0 130.00 150.00",
        "1.00s cpu tests/maps/test_a.py::test_one gw0 150.00 151.00",
    ]
    lines = timeline(record, tail=2)
    assert "warm-up: 0.0, 30.0 s" in lines and "gw1 collected: 11.0 s" in lines
    assert (
        "gw0: first test 11.0 s, last end 51.0 s, 15 s of CPU in 3 tests (38% of a core), 17.0 s waiting for the"
        " warm-up" in lines
    )
    assert lines[-2:] == [
        "  tests/maps/test_a.py gw0 50.0-51.0 s, 1.0 s of CPU",
        "  tests/foundation/test_colcon_build.py gw1 11.5-100.0 s, 60.0 s of CPU",
    ]
    assert seconds_per_file(record) == {
        "foundation/test_colcon_build.py": 60.0,
        "viewer/test_browser.py": 14.0,
        "maps/test_a.py": 1.0,
    }
    assert walls_per_file(record) == {  # a file's first start to its last end on its worker
        "foundation/test_colcon_build.py": 88.5,
        "viewer/test_browser.py": 39.0,
        "maps/test_a.py": 1.0,
    }


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
