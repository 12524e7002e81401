# The README's quick start: `make run` (set up, build, fly the main job on the emulator)
# and `make test`. Both create .venv on first use from the project's own files.
# .venv's interpreter: python3 on PATH, unless it was built without profile-guided optimisation (pyenv's default:
# no --enable-optimizations) while the distribution's /usr/bin/python3 (built with it and with link-time
# optimisation) is 3.11 or newer with venv. Measured on this machine against pyenv's CPython 3.11.7, Debian's
# 3.11.2 ran plain Python in 40 % less time and the emulator's step in 12 % less CPU (docs/performance.md, twelfth
# stop). `make PYTHON=...` chooses another; .venv keeps the interpreter it was made with until `make clean`.
ifndef PYTHON
PYTHON := $(shell python3 -c 'import sys, sysconfig; sys.exit(sys.base_prefix != "/usr" and "--enable-optimizations" \
	not in (sysconfig.get_config_var("CONFIG_ARGS") or ""))' 2>/dev/null && echo python3 || \
	(/usr/bin/python3 -c 'import ensurepip, sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null \
	&& echo /usr/bin/python3 || echo python3))
endif
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test test-fast lint typecheck fmu paper bench-tools test-tools clean

$(STAMP): pyproject.toml
	@echo ".venv from $(PYTHON): $$($(PYTHON) -c 'import sys; print(sys.version.split()[0], sys.executable)')"
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

# The plant FMU, the compiled flight code and bench step, and the project's own bytecode: an editable install has
# none, and with PYTHONDONTWRITEBYTECODE set (as on this machine) every `hil run`, emulator and sweep sample
# compiled ~170 modules from source again (~0.3 s of CPU a flight, measured: docs/performance.md). Only changed
# files are compiled again, and Python ignores a file older than its source.
fmu: $(STAMP)
	$(BIN)/python -m compileall -q hil firmware_interface plant_fmu
	$(BIN)/hil fmu build
	$(BIN)/python -m firmware_interface.emulator.warm_up
	$(BIN)/python -m hil.loop.step_frames

run: fmu
	$(BIN)/hil run scenarios/gust.yaml

# three tests at a time on two cores (a quarter of the suite waits on the wall clock: paced PX4 flights, exits
# within 2 s), a test file to a worker (its module fixtures' flights are flown once); the few tests that judge the
# wall clock to the millisecond run alone afterwards (docs/performance.md, "third stop" and "ninth stop"); a worker
# that dies fails the run at once (xdist's replacement of a dead worker once left a clean CI run waiting for ever)
test: fmu
	$(BIN)/python -m pytest -q -n 3 --dist loadfile --max-worker-restart=0 -m "not wallclock"
	$(BIN)/python -m pytest -q -m wallclock

# the unit tests: no end-to-end run, no PX4, nothing slow (under a minute)
test-fast: fmu
	$(BIN)/python -m pytest -q -m "not e2e and not px4 and not slow"

lint: $(STAMP)
	$(BIN)/ruff check .

typecheck: $(STAMP)
	$(BIN)/mypy

# docs/paper_reproduction.md and its figures, from flights of the code as it is (~15 min on 2 cores)
paper: fmu
	$(BIN)/python docs/paper_reproduction/build.py

# what benchmarks/loop_speed.py measures the machine's own floor with, beside a paced run: cyclictest (Debian's
# rt-tests; needs root, as apt-get does)
bench-tools:
	command -v cyclictest >/dev/null 2>&1 || (apt-get update -qq && apt-get install -y -qq rt-tests >/dev/null)

# what tests/test_pythonfmu_exit.py watches a pythonfmu plant's exit with: valgrind (Debian; needs root)
test-tools:
	command -v valgrind >/dev/null 2>&1 || (apt-get update -qq && apt-get install -y -qq valgrind >/dev/null)

clean:
	rm -rf $(VENV) build runs
