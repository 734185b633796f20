# ascc-ros-pkg: `make demo` runs the main job, `make test` runs every test.
# Both run scripts/setup.sh first (idempotent; fast when nothing changed).
SHELL := /bin/bash
ARGS ?=

.PHONY: setup demo test lint unit rostest bench screenshots clean

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

# every rviz config against its launch file (rviz/launches.yaml), headless, into
# docs/images/; ARGS='sim.rviz robot.rviz' renders only those
screenshots:
	@bash scripts/setup.sh --screenshots
	@source env.sh && python scripts/rviz_screenshots.py $(ARGS)

clean:
	rm -rf .ws output
