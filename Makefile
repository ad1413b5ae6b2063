# pyuss developer entry points. Two commands set everything up: `make demo` and `make test`.
# Each installs what it needs into .venv: the demo pyuss with every extra (`[all]`: the page and
# the gateway's faces, so that every command of README.md works after it), the tests, lint,
# type check, benchmarks and screenshots the test toolchain (the `test` extra).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
DEMO_STAMP := $(VENV)/.installed-demo
STAMP  := $(VENV)/.installed
# Most tests wait for telegrams at their baud rates, not for a core: pytest runs them in this
# many processes (pytest-xdist); `make pytest WORKERS=1` runs them one after the other. The
# browser tests run after them, one at a time: a Chromium beside three other test processes
# left the page's simulated drives answering late on a two-core machine.
WORKERS ?= 4
BROWSER_TESTS := tests/web/test_page.py tests/web/test_plant.py

.PHONY: demo test lint typecheck pytest bench clean venv screenshots test-windows

$(PY):
	$(PYTHON) -m venv $(VENV)

$(DEMO_STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[all]'
	touch $(DEMO_STAMP)

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(DEMO_STAMP) $(STAMP)

venv: $(STAMP)

demo: $(DEMO_STAMP)
	$(VENV)/bin/uss demo

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests bench .ci
	$(VENV)/bin/ruff format --check src tests bench .ci

# The code is checked as Linux, Windows and macOS see it (docs/platforms.md).
typecheck: $(STAMP)
	$(VENV)/bin/mypy --strict src
	$(VENV)/bin/mypy --strict --platform win32 src
	$(VENV)/bin/mypy --strict --platform darwin src

pytest: $(STAMP)
	bash .ci/system-deps tshark chromium mosquitto mosquitto-clients mbpoll
	$(PY) -m pytest -n $(WORKERS) $(addprefix --ignore=,$(BROWSER_TESTS))
	$(PY) -m pytest $(BROWSER_TESTS)

test: lint typecheck pytest

# bench/requirements.txt holds what only the benchmarks use (turboctl, the comparison of
# bench_turboctl.py); without it (offline) that benchmark says so and the others run.
bench: $(STAMP)
	-$(PY) -m pip install --quiet --disable-pip-version-check -r bench/requirements.txt
	$(PY) bench/run.py

# The browser tests save a picture of each view of the web page into build/screenshots/ on
# every run; this runs them and refreshes docs/images/ (shown by docs/web.md) from them.
screenshots: $(STAMP)
	bash .ci/system-deps chromium
	rm -rf build/screenshots
	$(PY) -m pytest tests/web/test_page.py tests/web/test_plant.py -q -p no:cacheprovider
	cp build/screenshots/*.png docs/images/

# The Windows lane (docs/windows-lane.md): pyuss's wheel installed into Windows CPython 3.13
# under Wine and run against pyuss on Linux. Its downloads are kept in build/wine.
test-windows: $(STAMP)
	bash .ci/system-deps wine wine64 gcc-mingw-w64-x86-64-win32
	$(PY) .ci/windows/lane.py

clean:
	rm -rf $(VENV) build dist .mypy_cache .pytest_cache .ruff_cache src/*.egg-info
