"""Tests of the benchmark, calibration and paper-reproduction tools (``benchmarks/``).

They may import ``benchmarks``; the product's tests (``tests/``) do not. ``make test``
runs both folders (``pytest -q tests benchmarks/tests``).
"""
