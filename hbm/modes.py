"""The modes of the eq. (17) operator and the static deflection along each element.

``K' = K + sum_e k_bar_e g_e g_e^T`` and ``M`` give the mass-normalised modes; when the
damping is diagonal in them the problem is *modal* (receptances of eq. 18-19). The
length scale of an element is the largest of its own (a backlash, a transmission-error
amplitude, :meth:`hbm.elements.Element.scale`) and its static deflection: the scale of
its unknowns (:mod:`hbm.condensation`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Modes", "modes", "static_deflection"]


@dataclass(frozen=True)
class Modes:
    """Modes of ``K'`` (eq. 17) with ``M``.

    Attributes
    ----------
    w2, phi
        Squared natural frequencies (rad^2/s^2, >= 0) and mass-normalised modes (columns).
    cj
        Diagonal of the modal damping ``phi^T C phi`` (1/s).
    modal
        True when ``phi^T C phi`` is diagonal and ``K'`` symmetric.
    kp_symmetric
        ``K'`` is symmetric (equilibrated, to 1e-12 of its largest eigenvalue).
    gj
        Modal directions ``phi^T g_e`` of the elements, (n_elements, n_modes).
    pfc, pfu
        Modal forcing ``phi^T F_c``, ``phi^T F_u`` (n_modes, n_harmonics).
    rigid
        Rigid-body modes that move no element (their static term is dropped).
    """

    w2: np.ndarray
    phi: np.ndarray
    cj: np.ndarray
    modal: bool
    kp_symmetric: bool
    gj: np.ndarray
    pfc: np.ndarray
    pfu: np.ndarray
    rigid: np.ndarray


def modes(kp: np.ndarray, m: np.ndarray, c: np.ndarray, directions, fc: np.ndarray,
          fu: np.ndarray, dof_eq: np.ndarray) -> Modes:
    """Modes of ``K' = kp`` with mass ``m``, equilibrated by ``D = diag(dof_eq)``;
    ``directions``: the elements' ``g_e``, each (n,).

    Raises ValueError if ``K'`` is not positive semi-definite, if a rigid-body mode moves
    an element, or if the static load (``fc[0]``) drives a rigid-body mode.
    """
    import scipy.linalg as sla

    d = dof_eq
    dd = np.outer(d, d)
    w2, phi = sla.eigh(0.5 * (kp + kp.T) * dd, m * dd)
    phi = d[:, None] * phi                                    # mass-normalised modes
    top = max(np.max(np.abs(w2)), 1e-300)
    if np.min(w2) < -1e-9 * top:
        raise ValueError(
            f"system.K: K + k_bar G G^T has a negative eigenvalue {np.min(w2):.3g}; "
            "the linear model must be positive semi-definite")
    w2 = np.clip(w2, 0.0, None)
    cm = phi.T @ c @ phi
    diag = np.diag(cm).copy()
    off = cm - np.diag(diag)
    cscale = max(np.max(np.abs(diag)), np.sqrt(top) * 1e-300, 1e-300)
    modal = bool(np.max(np.abs(off), initial=0.0) <= 1e-9 * cscale)
    kp_symmetric = bool(np.allclose(kp * dd, (kp * dd).T, rtol=0, atol=1e-12 * top))
    if not kp_symmetric:
        modal = False
    gj = np.stack([phi.T @ g for g in directions])            # (n_elements, n_modes)
    pfc = phi.T @ fc.T        # (n_modes, nS)
    pfu = phi.T @ fu.T
    moving = w2 <= 1e-12 * top
    rigid = moving.copy()
    for ge in gj:
        rigid &= np.abs(ge) <= 1e-12 * np.linalg.norm(ge)
    if np.any(moving & ~rigid):
        raise ValueError("system: a rigid-body mode of K + sum k_bar g g^T moves an element")
    if np.any(rigid):
        f0 = np.abs(pfc[rigid, 0]) + np.abs(pfu[rigid, 0])
        fscale = np.linalg.norm(fc[0]) + np.linalg.norm(fu[0]) + 1e-300
        if np.any(f0 > 1e-9 * fscale):
            raise ValueError(
                "excitation.constant[0]: the static load drives a rigid-body mode that the "
                "mesh does not restrain (no steady state)")
    return Modes(w2=w2, phi=phi, cj=diag, modal=modal, kp_symmetric=kp_symmetric, gj=gj,
                 pfc=pfc, pfu=pfu, rigid=rigid)


def static_deflection(md: Modes, kp: np.ndarray, g: np.ndarray, gj: np.ndarray,
                      fc0: np.ndarray, dof_eq: np.ndarray) -> float:
    """Static deflection ``|g^T K'^+ F_c,0|`` (m) along the direction ``g`` (modal: ``gj``,
    its modal components) under the mean load (modal sum when :attr:`Modes.modal`)."""
    keep = ~md.rigid
    static = 0.0
    if md.modal and np.any(keep):
        static = abs(float(np.sum(gj[keep] * md.pfc[keep, 0].real / md.w2[keep])))
    elif np.any(fc0 != 0):
        # static mesh deflection under the mean load, whatever the damping
        d = dof_eq
        x = d * np.linalg.lstsq(kp * np.outer(d, d), d * fc0.real, rcond=None)[0]
        static = abs(float(g @ x))
    return static
