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

$(VENV)/.deps-installed: pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test]'
	@touch $@

demo: setup
	$(PY) -m amr_bringup.demo

# Two pytest-xdist workers (tests/conftest.py gives each its own DDS domains), then the browser tests alone:
# in a worker of the whole suite their page twice never drew its controls in 90 s (alone, or beside the
# viewer and evaluation tests, it did; the cause is not known yet).
test: setup
	$(PY) -m pytest -q -n 2 --dist loadfile --ignore=tests/viewer/test_browser.py
	$(PY) -m pytest -q tests/viewer/test_browser.py

bench: setup
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test,bench]'
	@for script in bench/bench_*.py; do echo "== $$script"; $(PY) $$script || exit 1; done

clean:
	rm -rf $(VENV) build out .pytest_cache
