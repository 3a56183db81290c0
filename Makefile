# depot — the two commands: `make run` and `make test`.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV ?= .venv
PY := $(VENV)/bin/python
# `make run` installs what the service needs; `make test` (lint, bench, ...) adds the dev tools.
RUN_STAMP := $(VENV)/.installed-run
STAMP := $(VENV)/.installed-stamp
PIP := $(PY) -m pip install --quiet --progress-bar off --disable-pip-version-check
PURE := identification tail_check maintenance motion
TYPED := core ingest service transports $(PURE) bench

.PHONY: run test lint bench soak install clean format

$(RUN_STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	@echo "installing depot into $(VENV) (service dependencies only)"
	@$(PIP) -e .
	@touch $(RUN_STAMP)

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	@echo "installing depot and its development tools into $(VENV)"
	@$(PIP) -e '.[dev]'
	@touch $(STAMP) $(RUN_STAMP)

install: $(STAMP)

run: $(RUN_STAMP)
	@$(VENV)/bin/depot migrate
	@$(VENV)/bin/depot demo
	@# The simulator keeps the demo line alive beside the server and stops with it.
	@$(VENV)/bin/depot simulate --url http://$${DEPOT_HOST:-127.0.0.1}:$${DEPOT_PORT:-8000} & sim=$$!; \
	  trap "kill $$sim 2>/dev/null" EXIT; $(VENV)/bin/depot serve

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy $(TYPED)
	$(VENV)/bin/lint-imports

# `make test` runs two xdist workers (measured: make test 1570 s -> 859 s); each file's tests
# stay on one worker, each worker has its own databases (tests/conftest.py). The obstacle to this
# default (tests/tail_check/test_tail_check_fast_paths.py drew from a module-level RNG, so its
# verdicts depended on test order) is gone: each test draws from its own generator seeded by
# name (ef8c018). `make test PYTEST_WORKERS=0` runs in one process.
PYTEST_WORKERS ?= 2
test: lint
	$(VENV)/bin/pytest -n $(PYTEST_WORKERS) --dist loadgroup $(PYTEST_ARGS)

bench: $(STAMP)
	@for b in bench/[!_]*.py; do m=$$(basename $$b .py); echo "== bench.$$m"; $(PY) -m bench.$$m || exit 1; done

soak: $(STAMP)
	DEPOT_SOAK=1 $(VENV)/bin/pytest tests/reliability -m "slow or not slow" $(PYTEST_ARGS)

format: $(STAMP)
	$(VENV)/bin/ruff format .
	$(VENV)/bin/ruff check --fix .

clean:
	rm -rf $(VENV) var .pytest_cache .mypy_cache .ruff_cache
