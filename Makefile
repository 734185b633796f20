# ascc-ros-pkg: `make demo` runs the main job, `make test` runs every test.
# Both run scripts/setup.sh first (idempotent; fast when nothing changed).
SHELL := /bin/bash
ARGS ?=

.PHONY: setup demo test lint unit rostest bench clean

setup:
	@bash scripts/setup.sh

demo: setup
	@bash scripts/demo.sh $(ARGS)

test: setup
	@bash scripts/run_tests.sh

lint: setup
	@bash scripts/run_tests.sh --lint-only

bench: setup
	@bash scripts/run_benchmarks.sh

clean:
	rm -rf .ws output
