"""The docs hold: the README is short and starts with the two commands, every documented command and
Python example works, every link resolves, and the parameter tables are the specs'."""

from __future__ import annotations

import ast
import multiprocessing
import os
import re
import traceback
from pathlib import Path

import pytest
from support.doc_commands import DOC_FILES, ROOT, all_commands, check, code_blocks, is_node, parameter_docs

from amr_util.environment import BOOTSTRAP_VARIABLES

COMMANDS = all_commands()
PYTHON_EXAMPLES = [
    (path, first, body)
    for path in DOC_FILES
    for language, body, first in code_blocks(path.read_text(encoding="utf-8"))
    if language == "python"
]


def test_the_readme_is_short_and_its_first_two_commands_are_make_demo_and_make_test():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250
    first = [command for command in COMMANDS if command.where.startswith("README.md")][:2]
    assert [command.words for command in first] == [("make", "demo"), ("make", "test")]
    assert "make test" in (ROOT / ".ci" / "run").read_text(encoding="utf-8")  # CI runs the README's second


def test_the_docs_have_commands_to_check():
    assert len(COMMANDS) > 60 and {c.where.split(":")[0] for c in COMMANDS} >= {"README.md", "docs/amr_bringup.md"}


@pytest.mark.parametrize("command", COMMANDS, ids=str)
def test_every_documented_command_works(command):
    check(command)


def imported_modules(body: str) -> set[str]:
    """The modules an example imports by absolute name."""
    names = set()
    for node in ast.walk(ast.parse(body)):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def run_example(body: str, where: str, error_file: str) -> None:
    """An example run as `python -c` runs it (as __main__, from the repository's root), in a process forked from a
    server that has imported what the examples import: each example in a fresh process without paying numpy's,
    scipy's and the suite's imports again (about half an example's CPU)."""
    os.chdir(ROOT)
    try:
        exec(compile(body, where, "exec"), {"__name__": "__main__"})
    except Exception:  # a SystemExit goes on as the process's exit code, as `python -c` would give it
        Path(error_file).write_text(traceback.format_exc(), encoding="utf-8")
        raise SystemExit(1) from None


@pytest.fixture(scope="module")
def examples():
    """A forkserver context whose server preloads every module the examples import; its server is started with the
    environment a child of the venv's Python needs (without the wheels' bootstrap markers)."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(sorted(set().union(*(imported_modules(body) for _, _, body in PYTHON_EXAMPLES))))
    saved = {name: os.environ.pop(name) for name in BOOTSTRAP_VARIABLES if name in os.environ}
    try:
        context.Process(target=int).start()  # starts the server now, with this environment
    finally:
        os.environ.update(saved)
    return context


@pytest.mark.parametrize("path, line, body", PYTHON_EXAMPLES, ids=lambda v: str(v)[-40:])
def test_every_python_example_runs(path, line, body, tmp_path, examples):
    where, error_file = f"{path.relative_to(ROOT)}:{line}", tmp_path / "error.txt"
    process = examples.Process(target=run_example, args=(body, where, str(error_file)))
    process.start()
    process.join(timeout=120)
    if process.is_alive():
        process.kill()
        process.join()
        pytest.fail(f"{where}: still running after 120 s")
    assert process.exitcode == 0, f"{where}:\n{error_file.read_text(encoding='utf-8') if error_file.exists() else ''}"


def anchors(path: Path) -> set[str]:
    """GitHub's heading anchors of a Markdown file."""
    found = set()
    for heading in re.findall(
        r"^#+ (.+)$", re.sub(r"^```.*?^```", "", path.read_text(encoding="utf-8"), flags=re.S | re.M), re.M
    ):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        found.add(slug)
    return found


DECISION_RECORDS = sorted((ROOT / "docs" / "decisions").glob("*.md"))
"""Dated records of how a design or figure was reached: their links are checked, their commands are history."""


@pytest.mark.parametrize("path", DOC_FILES + DECISION_RECORDS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_link_resolves(path):
    text = re.sub(r"^```.*?^```", "", path.read_text(encoding="utf-8"), flags=re.S | re.M)
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if target.startswith(("http://", "https://")):
            continue
        file, _, anchor = target.partition("#")
        linked = (path.parent / file).resolve() if file else path
        assert linked.exists(), f"{path.relative_to(ROOT)}: link to {target}: no such file"
        if anchor and linked.suffix == ".md":
            assert anchor in anchors(linked), f"{path.relative_to(ROOT)}: link to {target}: no such heading"


def test_the_parameter_tables_are_the_specs():
    assert parameter_docs.problems() == [], "run .venv/bin/python scripts/parameter_docs.py"


def test_every_node_has_its_parameter_table():
    nodes = {
        f"{p.parent.name}/{p.name}" for p in (ROOT / "resource" / "lib").glob("*/*") if is_node(p.parent.name, p.name)
    }
    assert len(nodes) >= 11 and nodes <= {node.key for node in parameter_docs.NODES}


def ament_packages() -> set[str]:
    return {path.name for path in (ROOT / "resource" / "ament_index").iterdir()}


def test_the_package_listings_name_every_package():
    text = (ROOT / "docs" / "ros_user.md").read_text(encoding="utf-8")
    listed = re.search(r"\$ ros2 pkg list \| grep amr\n((?:amr_\w+\n)+)", text)[1].split()
    assert set(listed) == ament_packages() | {"amr_interfaces"} and listed == sorted(listed)
    registered = re.search(r"registering the ament packages (.*?)\) with", text, re.S)[1]
    assert set(re.findall(r"`(amr_\w+)`", registered)) == ament_packages()
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert ament_packages() | {"amr_interfaces"} <= set(re.findall(r"^\| `(amr_\w+)` \|", readme, re.M))


def test_the_node_list_names_the_nodes_of_the_stacks_it_was_taken_from():
    from amr_bringup.stack_config import load_bringup

    text = (ROOT / "docs" / "ros_user.md").read_text(encoding="utf-8")
    taken_from = re.search(r"against ((?:`amr-bringup \w+`(?: and )?)+)", text)[1]
    stacks = [load_bringup(name) for name in re.findall(r"`amr-bringup (\w+)`", taken_from)]
    expected = {f"/{node.name}" for stack in stacks for node in stack.nodes} | {f"/{s.manager_name}" for s in stacks}
    listed = re.search(r"\$ ros2 node list\n((?:/\w+\n)+)", text)[1].split()
    assert set(listed) == expected


@pytest.mark.parametrize(
    "line, words",
    [
        (
            "ros2 run amr_bringup recorder --ros-args -p path:=out/run.mcap -p topics:=[/scan, /tf]",
            "quote",
        ),  # the shell splits it
        (
            ".venv/bin/amr-bringup maze_sim -p wall_follower.kpp:=3.0",
            "kpp: not a parameter of amr_control/wall_follower",
        ),
        (".venv/bin/amr-bringup maze_sim -p wall_follower.kp:=-3.0", "kp: must be >= 0"),
        (".venv/bin/amr-bringup maze_navigatio", "no such file"),
        ("ros2 run amr_localization particle_filter --ros-args -p global_frame:=map", "global_frame: not a parameter"),
        ('ros2 service call /solve_ik amr_interfaces/srv/SolveIK "{chain: ur5, targett: {}}"', "no field 'targett'"),
        ("python bench/bench_ik.py --no-such-flag", "no option --no-such-flag"),
        ("make deploy", "no such target"),
        ("make test TEST_WORKER=3", "the Makefile reads no TEST_WORKER"),
        ("ros2 launch amr_bringup maze_sim.launch.py wrld:=x.yaml", "unknown argument 'wrld'"),
    ],
)
def test_the_checker_refuses_broken_commands(line, words):
    from support.doc_commands import Command, split_commands

    with pytest.raises((AssertionError, ValueError)) as error:
        for command in split_commands(line):
            check(Command(tuple(command), "test"))
    assert words in str(error.value)
