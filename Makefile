# Every install step of the project lives here; a fresh machine needs only python3.11, pip and gcc.
PY ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install demo lint test bench pretrained clean

$(BIN)/python:
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --upgrade pip

# torch first, pinned, so pip takes the CPU wheel on disk instead of a multi-GB CUDA build.
$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/pip install torch==2.13.0
	$(BIN)/pip install -e '.[test,bench,testbed]'
	touch $(STAMP)

install: $(STAMP)

# The main job end to end: a robot whose parameters differ from the nominal ones flops (the
# "observed" data, with 1 mm of motion-capture noise), then the identifier recovers a
# distribution over the 15 parameters and prints it next to the truth, with a verdict each.
DEMO_THETA := rod_length=1.70 pretension=140 damping=210
demo: $(STAMP)
	$(BIN)/tensegrid simulate --out out/demo --theta $(DEMO_THETA) --noise 0.001 --seed 1
	$(BIN)/tensegrid identify out/demo/trajectory.nc --budget 60 --out out/demo/identify

# ruff (pyflakes, pycodestyle, import order, bugbear, pyupgrade) over the library and the tutorials, mypy over
# the library (the packages are listed in pyproject.toml); both configured in pyproject.toml.
lint: $(STAMP)
	$(BIN)/ruff check physics embeddings belief criticism planners docs
	$(BIN)/mypy

test: $(STAMP) lint
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --durations=20

bench: $(STAMP)
	$(BIN)/python benchmarks/physics_speed.py
	$(BIN)/python benchmarks/parameter_effects.py

# The latent decoder shipped for the T6's default box (embeddings/data/t6-ae-cf-5.json): the ae-cf-5
# of benchmarks/paper.py, 1,200 simulated trajectories (about an hour on 2 cores; cached).
pretrained: $(STAMP)
	$(BIN)/python benchmarks/paper.py --write-pretrained

clean:
	rm -rf $(VENV) out .pytest_cache
