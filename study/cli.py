"""The ``geardyn`` command line (skeleton; filled in by the study issue)."""
from __future__ import annotations

import argparse


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="geardyn")
    parser.add_argument("command", choices=["mesh", "reduce", "run", "export", "report", "convergence"])
    parser.add_argument("scene")
    parser.add_argument("--out", required=True)
    parser.parse_args(argv)
    return 2
