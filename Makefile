# miketalk: every target does set-up first and is idempotent.
#   make run    set-up, then the default workflow on the synthetic face (results/)
#   make test   set-up, then lint and tests (including the .test/ workflow end to end)
#   make bench  set-up, then the timed benchmarks (results/bench/)

SHELL := /bin/bash
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
APT_PACKAGES := festival festvox-kallpc16k festvox-kdlpc16k festvox-us-slt-hts libegl1 libgl1-mesa-dri chromium gcc python3-dev espeak-ng
STAMP := $(VENV)/.installed
CORES ?= all
export VTK_DEFAULT_OPENGL_WINDOW := vtkEGLRenderWindow
export PYTHONHASHSEED := 0

.PHONY: setup apt bytecode run test lint bench report clean

setup: apt $(STAMP) bytecode

# The sources' bytecode, compiled now (only what changed): the install is editable, so
# nothing else compiles it where PYTHONDONTWRITEBYTECODE is set, and every command would
# compile miketalk's modules again (s1's 10-word say: 0.09 s of its 1.6 s of CPU).
bytecode: $(STAMP)
	@$(BIN)/python -m compileall -q src >/dev/null

apt:
	@missing=$$(for p in $(APT_PACKAGES); do dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "installing apt packages:" $$missing; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing; \
	  else \
	    echo "miketalk needs these Debian packages: $$missing"; \
	    echo "run as root:  apt-get update && apt-get install -y $$missing"; \
	    exit 1; \
	  fi; \
	fi

$(STAMP): pyproject.toml setup.py src/miketalk/render/_morph_kernels.c requirements/recognize.txt
	@command -v $(PYTHON) >/dev/null || { echo "$(PYTHON) not found; set PYTHON=/path/to/python3.11"; exit 1; }
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q --no-deps --require-hashes -r requirements/recognize.txt
	$(BIN)/pip install -q -e '.[dev]'
	touch $@

run: setup
	$(BIN)/snakemake --cores $(CORES) --rerun-incomplete

report: run
	$(BIN)/snakemake --cores 1 --report results/report.html

lint: setup
	$(BIN)/ruff check src synth_face tests workflow/scripts
	$(BIN)/ruff format --check src synth_face tests workflow/scripts
	$(BIN)/snakefmt --check Snakefile workflow/rules
	$(BIN)/snakemake --lint --cores 1

test: setup lint
	MIKETALK_NO_SKIP=1 $(BIN)/pytest -q -n 2 --dist loadfile --durations=15

bench: run
	$(BIN)/python -m miketalk_lab.bench --out results/bench --results-doc docs/results.md

clean:
	rm -rf results .snakemake .test/results .test/.snakemake
