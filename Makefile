# Two commands do all set-up on a fresh Debian 12 machine (see README):
#   make demo   -> install what is missing, run the default pump scene into out/
#   make test   -> install what is missing, run the test suite (incl. an mpirun -n 2 case):
#                  the product's tests/ and the benchmark tools' benchmarks/tests/
PY      := .venv/bin/python
GEARDYN := .venv/bin/geardyn
SCENE   ?= scenes/pump.toml
OUT     ?= out
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1
export OMP_NUM_THREADS := 1
export OPENBLAS_NUM_THREADS := 1

.PHONY: setup demo test test-slow lint bench clean

setup:
	@bash scripts/bootstrap.sh

demo: setup
	$(GEARDYN) run $(SCENE) --out $(OUT)/pump
	$(GEARDYN) run scenes/gear-pair-sdof.toml --out $(OUT)/gear-pair-sdof
	@echo "demo outputs:"; for d in $(OUT)/pump $(OUT)/gear-pair-sdof; do \
	  echo "  $$d/report.md  (results.h5, PNG plots$$(ls $$d/*.xdmf >/dev/null 2>&1 && echo ', housing XDMF for ParaView'))"; \
	  ls $$d | sed 's/^/      /'; done

# one pytest worker per core (at most 4), each test file on one worker (its module
# fixtures computed once): 9 min instead of 16 on 2 cores
XDIST   := -n auto --maxprocesses=4 --dist loadfile

test: setup
	$(PY) -m pytest -q $(XDIST) tests benchmarks/tests

test-slow: setup
	$(PY) -m pytest -q $(XDIST) -m slow tests benchmarks/tests

lint: setup
	$(PY) -m ruff check core gears geometry fem reduction machines hbm study tests benchmarks

bench: setup
	$(PY) -m benchmarks.run_all

clean:
	rm -rf out .cache .pytest_cache
