# navd: two commands on a fresh machine with Python 3.11 and git.
#   make demo   sets up .venv if missing and runs navd's main job on built-in defaults
#   make test   sets up .venv if missing and runs the whole test suite (lint, types, tests)

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint typecheck unit clean

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	@command -v systemd-analyze >/dev/null || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
		&& apt-get update -qq && apt-get install -y -qq systemd >/dev/null; } \
		|| echo "note: systemd-analyze is unavailable; the unit file check will be skipped"
	@{ command -v chromium >/dev/null && command -v chromedriver >/dev/null; } \
		|| { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
		&& apt-get update -qq && apt-get install -y -qq chromium chromium-driver >/dev/null; } \
		|| echo "note: chromium is unavailable; the operator page's browser test will be skipped"
	@{ command -v mosquitto >/dev/null || test -x /usr/sbin/mosquitto; } \
		|| { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
		&& apt-get update -qq && apt-get install -y -qq mosquitto >/dev/null; } \
		|| echo "note: mosquitto is unavailable; the fleet's broker tests will be skipped"
	@touch $(STAMP)

demo: $(STAMP)
	$(BIN)/navd demo --out demo-output

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy
	$(BIN)/pytest

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache
