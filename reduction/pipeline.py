"""One call from an ``fem.FEModel`` to a validated :class:`ROM`."""

from __future__ import annotations

import logging
from typing import Any

from reduction.craig_bampton import craig_bampton
from reduction.rom import ROM, build_rom
from reduction.validate import validate_rom

log = logging.getLogger(__name__)


def reduce_fe_model(
    model: Any,
    km_mean,
    n_modes: int | None = None,
    f_cut_hz: float | None = None,
    xi=0.05,
    n_check: int | None = None,
    tol: float = 1e-3,
) -> ROM:
    """Craig–Bampton ROM of an ``fem.FEModel`` onto its gear DOF (6 per gear body),
    validated.

    Parameters
    ----------
    model : fem.FEModel
        Needs ``M``, ``K`` (distributed PETSc), ``gear_dofs`` (6 ints per gear body, in
        the order of the bodies) and ``G`` (``(n_c, E)``, one direction per mesh, eq. 11).
    km_mean : float or array (E,)
        Mean mesh stiffness k̄_m [N/m] for eq. (17), (19), (31), shared or one per mesh.
    n_modes, f_cut_hz :
        Number of fixed-interface modes, or the cut-off frequency [Hz] below
        which all are kept (see :func:`reduction.cutoff_from_speed`); exactly one.
    xi : float or array
        Modal damping ratio(s) of the coupled modes (eq. 18).
    n_check : int, optional
        Modes compared with the full model (Fig. 9); None skips the validation.
    tol : float
        Relative error defining the validity frequency.
    """
    if model.gear_dofs is None or model.G is None:
        raise ValueError("model.gear_dofs / model.G = None: the model has no gear mesh")
    cb = craig_bampton(model.M, model.K, model.gear_dofs, n_modes=n_modes, f_cut_hz=f_cut_hz)
    rom = build_rom(cb, model.G, km_mean, xi=xi)
    if n_check is not None:
        rom.validation = validate_rom(
            rom, model.M, model.K, model.gear_dofs, model.G, km_mean, min(n_check, rom.n_r), tol
        )
    return rom
