# The two commands of the README's quick start, and a few more for developers.
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint bench setup lock clean

$(STAMP): pyproject.toml scripts/setup.sh requirements/constraints.txt
	bash scripts/setup.sh $(VENV)
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)  ## set up, then run the shipped LEGATO lid policy on every embodiment
	$(BIN)/legato-drake demo

test: $(STAMP)  ## set up, then run the whole test suite (ruff, pytest, the notebooks)
	$(BIN)/ruff check legato_drake tests benchmarks models scripts
	$(BIN)/python -m pytest -n 2 --durations=15

bench: $(STAMP)  ## speed benchmarks (tables on stdout)
	$(BIN)/python benchmarks/bench_closed_loop.py
	$(BIN)/python benchmarks/bench_system_overhead.py
	$(BIN)/python benchmarks/bench_ik.py
	$(BIN)/python benchmarks/bench_invariants.py
	$(BIN)/python benchmarks/bench_training_step.py
	$(BIN)/python benchmarks/bench_policy.py
	$(BIN)/python benchmarks/bench_backends.py
	$(BIN)/python benchmarks/bench_evaluation.py

lock: $(STAMP)  ## refresh requirements/constraints.txt from the tested venv (deliberately)
	{ sed -n '/^#/p' requirements/constraints.txt; \
	  $(BIN)/python -m pip freeze --exclude-editable | grep -v '^#' | \
	  sed -e 's/^torch==\([^+]*\)+.*/torch==\1/'; } > requirements/constraints.txt.new
	mv requirements/constraints.txt.new requirements/constraints.txt

clean:
	rm -rf $(VENV) replays .pytest_cache
