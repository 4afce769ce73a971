#!/usr/bin/env bash
# Install what is missing for geardyn on Debian 12 (bookworm), idempotently:
#   1. Debian's FEniCSx stack (DOLFINx 0.5.2, gmsh 4.8, PETSc/SLEPc 3.18, MPI, CalculiX)
#      and OpenBLAS, which takes over libblas.so.3/liblapack.so.3 (update-alternatives)
#      for NumPy, SciPy and PETSc (docs/blas.md);
#   2. a virtual environment .venv from /usr/bin/python3 with --system-site-packages,
#      pip-installed extras pinned by constraints.txt (Debian's NumPy 1.24 stays).
# Quick when everything is there: it checks dpkg and a stamp file and exits.
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES=(
  python3-dolfinx-real python3-gmsh python3-petsc4py-real python3-slepc4py-real
  python3-h5py python3-scipy python3-venv python3-pip python3-setuptools
  openmpi-bin calculix-ccx libopenblas0-pthread
)

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "bootstrap: installing Debian packages: ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

if [ ! -x .venv/bin/python ]; then
  echo "bootstrap: creating .venv from /usr/bin/python3 (--system-site-packages)"
  /usr/bin/python3 -m venv --system-site-packages .venv
fi

stamp=.venv/.geardyn-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ constraints.txt -nt "$stamp" ]; then
  echo "bootstrap: pip-installing geardyn (editable) with its extras"
  .venv/bin/python -m pip install -q --disable-pip-version-check -c constraints.txt -e ".[viz,dev]"
  .venv/bin/python - <<'PY'
import numpy, petsc4py, dolfinx, gmsh  # noqa: F401  fail here, not in the tests
from petsc4py import PETSc  # noqa: F401
assert numpy.__version__.startswith("1.24"), numpy.__version__
PY
  touch "$stamp"
fi
