# navd: two commands on a fresh machine with Python 3.11 and git.
#   make demo   sets up .venv if missing and runs navd's main job on built-in defaults
#   make test   sets up .venv if missing and runs the whole test suite (lint, types, tests)

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
# pytest workers: one per core, at most two. The end-to-end tests drive real daemons in real
# time, so more workers than cores would measure the machine, not navd.
JOBS   ?= $(shell $(PYTHON) -c 'import os; n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(); print(min(2, n or 1))')

JS     := tests/js

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

# third-party JavaScript peers the tests drive navd with (vda-5050-lib); their tests skip,
# saying why, where npm or its registry cannot be reached
$(JS)/node_modules/.installed: $(JS)/package.json $(JS)/package-lock.json
	@{ command -v npm >/dev/null || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
		&& apt-get update -qq && apt-get install -y -qq nodejs npm >/dev/null; }; } \
		&& (cd $(JS) && npm ci --silent --no-audit --no-fund) && touch $@ \
		|| echo "note: npm or its registry is unavailable; the tests against vda-5050-lib will be skipped"

demo: $(STAMP)
	$(BIN)/navd demo --out demo-output

test: $(STAMP) $(JS)/node_modules/.installed
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy
	$(BIN)/pytest --numprocesses $(JOBS) --dist loadfile

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache $(JS)/node_modules
