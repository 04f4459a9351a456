# tx200-twin: two commands on a fresh machine: `make demo` and `make test`.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow lint bench clean

$(BIN)/python:
	$(PY) -m venv $(VENV)

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	$(BIN)/python -m compileall -q twin
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/tx200-twin demo --out out/demo

# bytecode written even where the environment says not to (PYTHONDONTWRITEBYTECODE): the CLI processes the suite
# starts, and the workers' test modules, load it instead of compiling every module again (~4 s); the numba
# kernels compiled once, before the workers start, not in each of them (twin/apps/warm.py)
test: $(STAMP)
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m twin.apps.warm
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder

test-slow: $(STAMP)
	$(BIN)/python -m twin.apps.warm
	$(BIN)/python -m pytest -q -m slow -n 2 --dist loadfile

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy twin

bench: $(STAMP)
	$(BIN)/python -m compileall -q twin  # the bytecode a wheel install has: startup is measured as users meet it
	$(BIN)/tx200-twin bench --json benchmarks/results.json --readme README.md
	$(BIN)/python -m twin.apps.bench_suite benchmarks/suite.json  # the suite's own time (make test's command)

clean:
	rm -rf out .pytest_cache .mypy_cache .ruff_cache
