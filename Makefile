# The README's quick start: `make run` (set up, build, fly the main job on the emulator)
# and `make test`. Both create .venv on first use from the project's own files.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test fmu clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

fmu: $(STAMP)
	$(BIN)/hil fmu build

run: fmu
	$(BIN)/hil run scenarios/gust.yaml

test: fmu
	$(BIN)/python -m pytest -q

clean:
	rm -rf $(VENV) build runs
