# The two commands of the README: `make demo` (set up, then run the main job) and `make test`.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python

# DDS stays on this machine, in a domain of this run's own (override: make test ROS_DOMAIN_ID=42).
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export ROS_DOMAIN_ID ?= $(shell awk 'BEGIN { srand(); print int(10 + rand() * 90) }')

.PHONY: setup demo test bench clean

setup: $(VENV)/.deps-installed
	@$(PY) scripts/install_ros_layout.py
	@$(PY) scripts/build_interfaces.py

# pip brings uv (a PyPI wheel with its binary), uv installs the rest: the versions pip would resolve, in a fraction of
# pip's CPU (docs/testing.md). uv reads its own settings (UV_DEFAULT_INDEX, ...), not pip's configuration: where it
# cannot install (an index only pip is configured for), pip does.
$(VENV)/.deps-installed: pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check uv==0.13.9 \
		&& $(VENV)/bin/uv pip install --quiet --python $(PY) -e '.[test]' \
		|| $(PY) -m pip install --quiet --disable-pip-version-check -e '.[test]'
	@touch $@

demo: setup
	$(PY) -m amr_bringup.demo

# Lint and format first (ruff, configured in pyproject.toml), then one run, four pytest-xdist workers for two cores
# (the tests wait in real time about a third of theirs: the third and fourth workers' CPU fills the waits;
# tests/conftest.py gives each worker its own DDS domains), the browser tests among the rest (a stack that does not
# come up is stopped, and a viewer that lost its port is started on another); the 30 slowest tests listed at the end, where the suite's time
# goes. The files are handed out longest first (tests/support/schedule.py; xdist's own order is by test count).
# Python writes its bytecode even where PYTHONDONTWRITEBYTECODE is set: uv installs without .pyc, and every node
# process would compile numpy, scipy and rclpy again (docs/testing.md). TEST_WORKERS=3 tries another number of workers.
test: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -q -n $(or $(TEST_WORKERS),4) --dist loadfile --no-loadscope-reorder --durations=30

bench: setup
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test,bench]'
	@for script in bench/bench_*.py; do echo "== $$script"; $(PY) $$script || exit 1; done

clean:
	rm -rf $(VENV) build out .pytest_cache
