"""The run's quantities that ``paper.md`` sets beside the paper's Sect. 4 findings.

From the results of the three excitation cases (:mod:`study.studies.excitations`): the
curves of each case, the ``all`` case's solutions at the paper's speeds (Newton from the
nearest branch point, with their Floquet verdict and, for an unstable orbit, the time
response the machine settles on), their IPP sequences and spectra, and the cached ROM's
mode with most mesh energy and its shift under half the mesh stiffness (T.33).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from hbm import MeshPeriodEnvelope, mesh_period_envelope, point_stats, spectrum
from study.outputs.curves import CurveSummary, Peak, is_unstable
from study.scene.data import Scene
from study.studies.excitations import case_curves
from study.studies.paper.findings import IPP_KEYS, SPECTRUM_SPEEDS

logger = logging.getLogger(__name__)

__all__ = ["IppAt", "SpectrumAt", "PaperInputs", "comparison_inputs", "solution_at",
           "rom_measures"]


@dataclass(frozen=True)
class IppAt:
    """IPP sequence of one solution: target and actual speed (rpm), how it was obtained,
    and its ``stability`` (a kind of :data:`hbm.stability.KINDS`; "" not computed)."""

    target: float
    rpm: float
    ipp: np.ndarray
    how: str
    stability: str = ""


@dataclass(frozen=True)
class SpectrumAt:
    """Harmonics at one speed per shaft order: mesh load ``amplitude`` (N) and dynamic
    transmission error ``dte`` (m); ``peak_to_peak`` of the mesh load in time (N);
    ``envelope`` its mesh-period envelope over one turn (the slow modulation);
    ``stability`` as :attr:`IppAt.stability`; ``machine`` see below."""

    rpm: float
    orders: np.ndarray
    amplitude: np.ndarray
    teeth: int
    dte: np.ndarray
    peak_to_peak: float
    envelope: MeshPeriodEnvelope | None = None
    stability: str = ""
    #: when the orbit is unstable and time responses are asked for (``[outputs]
    #: attractor_transient_turns``): (turns left out, turns analysed, the envelope of
    #: the time response from the orbit), the machine's modulation
    machine: tuple[int, int, MeshPeriodEnvelope] | None = None

    def at(self, order: int, dte: bool = False) -> float:
        """Amplitude of one shaft order (0 if the set lacks it)."""
        a = self.dte if dte else self.amplitude
        sel = self.orders == order
        return float(a[sel][0]) if np.any(sel) else 0.0

    def largest(self, dte: bool = False) -> int:
        """Shaft order of the largest harmonic above the mean."""
        a = self.dte if dte else self.amplitude
        sel = self.orders > 0
        return int(self.orders[sel][int(np.argmax(a[sel]))])


@dataclass
class PaperInputs:
    """What :func:`study.studies.paper.report.paper_markdown` compares; every run
    quantity optional."""

    scene: str
    torque: float
    static_load: float
    cases: dict[str, CurveSummary] = field(default_factory=dict)
    primary: dict[str, Peak | None] = field(default_factory=dict)
    ipp: dict[float, IppAt | str] = field(default_factory=dict)
    #: at the speeds of :data:`SPECTRUM_SPEEDS`, or why not
    spectra: dict[float, SpectrumAt | str] = field(default_factory=dict)
    mesh_mode: tuple[float, float] | None = None
    #: the same among the modes the mesh harmonics reach (f >= ``reached_from`` Hz)
    reached_mode: tuple[float, float] | None = None
    reached_from: float = 0.0
    #: dynamic-factor peak [Hz] and its shift ratio under k̄/2 (T.33)
    softening: tuple[float, float] | None = None
    #: per case, (start speed [rpm], mesh-load std [N]) of the time response on the
    #: unstable segment at the primary peak (``[outputs] attractor_transient_turns``)
    machine: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: per speed of :data:`FIGURES`, the file name of the run's time-series plot there
    figures: dict[float, str] = field(default_factory=dict)
    #: the scene's ``[calibration]``: :data:`PAPER` key -> what the scene was fitted to
    calibration: dict[str, str] = field(default_factory=dict)


def solution_at(result, rpm: float):
    """The solution at ``rpm``: Newton at that speed from the nearest branch point
    (stable preferred), or that point itself if Newton fails. Returns (Point, how)."""
    from hbm import ConvergenceError
    from study.outputs.points import nearest_point

    _, pt = nearest_point(result, rpm)
    if abs(pt.rpm - rpm) <= 1e-9 * rpm:
        return pt, "branch point"
    try:
        p = result.problem.solve(rpm, x0=pt.unknowns, tol=result.scene.continuation.tolerance)
    except ConvergenceError as exc:
        logger.warning("no solution at %g rpm from the branch point at %.1f rpm (%s); using "
                       "that point", rpm, pt.rpm, exc)
        return pt, "nearest branch point"
    return p, f"solved from the branch point at {pt.rpm:.1f} rpm"


def _stability_kind(result, point) -> str:
    """Kind of :data:`hbm.stability.KINDS` of a solution off the branch ("" when the
    Floquet analysis fails: logged, and the rows then say nothing of stability)."""
    from hbm.stability import stability
    try:
        return stability(result.problem, point).kind
    except Exception as exc:                    # noqa: BLE001 - reported, the table goes on
        logger.warning("stability at %.1f rpm not computed: %s", point.rpm, exc)
        return ""


def _machine(result, point):
    """(turns left out, turns analysed, envelope) of the time response from ``point``
    when the scene asks for time responses (``[outputs] attractor_transient_turns`` > 0),
    else None; a failed integration is logged and gives None."""
    from study.outputs.attractors import scene_time_response

    try:
        tr = scene_time_response(result, point)
    except (RuntimeError, ValueError) as exc:
        logger.warning("time integration at %.1f rpm failed: %s", point.rpm, exc)
        return None
    return None if tr is None else (tr.transient, tr.window, tr.envelope)


def _in_range(result, rpm: float) -> bool:
    br = result.branch
    return float(np.min(br.rpm)) <= rpm <= float(np.max(br.rpm))


def _range_text(result) -> str:
    br = result.branch
    return f"outside the computed range {np.min(br.rpm):.0f}–{np.max(br.rpm):.0f} rpm"


def comparison_inputs(scene: Scene, results: dict, solved: dict | None = None):
    """:class:`PaperInputs` of the excitation cases' results (their curves,
    :func:`study.studies.excitations.case_curves`; IPP, spectra and mesh mode from the
    ``all`` case). ``solved``, if given, receives the ``all`` case's solutions at the
    paper's speeds: ``{rpm: (Point, how, stability kind)}``."""
    curves = case_curves(results)
    inp = PaperInputs(scene.name, scene.load.torque, scene.static_load, cases=curves.cases,
                      primary=curves.primary, machine=curves.machine,
                      calibration=dict(scene.calibration))
    r = results.get("all")
    if r is None:
        return inp
    solved = {} if solved is None else solved
    for target in (*IPP_KEYS, *SPECTRUM_SPEEDS):
        if target not in solved and _in_range(r, target):
            p, how = solution_at(r, target)
            solved[target] = (p, how, _stability_kind(r, p) if scene.hbm.stability else "")
    for target in IPP_KEYS:
        if target not in solved:
            inp.ipp[target] = _range_text(r)
            continue
        p, how, kind = solved[target]
        inp.ipp[target] = IppAt(target, p.rpm, point_stats(r.problem, p)[0].ipp, how, kind)
    for target in SPECTRUM_SPEEDS:
        if target not in solved:
            inp.spectra[target] = _range_text(r)
            continue
        p, _, kind = solved[target]
        sp = spectrum(r.problem, p)
        unstable = is_unstable(kind)
        inp.spectra[target] = SpectrumAt(p.rpm, sp["shaft_order"], sp["amplitude"],
                                         scene.gear.teeth, sp["dte_amplitude"],
                                         sp["peak_to_peak"], mesh_period_envelope(r.problem, p),
                                         kind, _machine(r, p) if unstable else None)
    rom = r.rom
    if rom is not None and getattr(rom, "mesh_energy", None) is not None:
        f_min = scene.gear.teeth * scene.continuation.speed[0] / 60.0  # H_Z, lowest speed
        inp.mesh_mode, inp.reached_mode, inp.softening = rom_measures(
            rom, scene.damping.modal_ratio, f_min)
        inp.reached_from = f_min
    return inp


def rom_measures(rom, xi: float, f_min: float = 0.0) -> tuple[tuple[float, float], ...]:
    """Of a cached ROM (:class:`machines.rom.RomData`): the mode with most mesh energy
    ``(Hz, ρ)`` (eq. 31), the same among the modes at or above ``f_min`` [Hz] (those the
    mesh harmonics reach), and the dynamic-factor peak near the latter with its shift
    under k̄/2 ``(Hz, f½/f)`` (T.33), for modal damping ratio ``xi``."""
    f, rho = np.asarray(rom.frequencies_hz), np.asarray(rom.mesh_energy)
    j = int(np.argmax(rho))
    k = int(np.argmax(np.where(f >= f_min, rho, 0.0)))
    return ((float(f[j]), float(rho[j])), (float(f[k]), float(rho[k])),
            rom.mesh_softening(xi, f_min=f_min))
