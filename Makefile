# Two commands for a fresh machine (Python >= 3.11 with pip and venv):
#   make run          set up .venv and run the main job on the built-in benchmark (writes results/)
#   make test         set up .venv and run the whole test suite (on every core, one BLAS thread per worker)
# Numerical robustness (the bits differ between CPUs and BLAS kernels; the tests' error bounds must not):
#   make test-blas    the numerically sensitive tests (marker "numerics") under other OpenBLAS kernels and
#                     1 and 2 BLAS threads, one line per configuration; BLAS_TESTS=all: the whole suite
#   make test-kernel  the "numerics" tests under one other kernel (KERNEL=Prescott; what CI runs)
#   make readme-figures  the figures the README points to -> docs/figures.md (benchmarks/readme_figures.py)
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
OUT ?= results
# pytest-xdist workers for `make test` (auto: one per core)
WORKERS ?= auto
KERNEL ?= Prescott
BLAS_KERNELS ?= Prescott Nehalem Sandybridge
BLAS_THREADS ?= 1 2
BLAS_TESTS ?= numerics
# one BLAS thread per test worker: the workers use the cores, BLAS threads would only contend
SERIAL_BLAS := OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1

.PHONY: run test test-blas test-kernel readme-figures setup clean

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

setup: $(BIN)/.installed

run: setup
	$(BIN)/jointid reproduce --out $(OUT)

test: setup
	$(SERIAL_BLAS) $(BIN)/python -m pytest -q -n $(WORKERS) --dist loadfile

test-blas: setup
	$(BIN)/python tests/run_blas_kernels.py --kernels $(BLAS_KERNELS) --threads $(BLAS_THREADS) --tests $(BLAS_TESTS)

test-kernel: setup
	$(BIN)/python tests/run_blas_kernels.py --kernels $(KERNEL) --threads 1 --tests numerics -- -n $(WORKERS) --dist loadfile

readme-figures: setup
	$(BIN)/python benchmarks/readme_figures.py --reproduce

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
