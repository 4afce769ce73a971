"""Small models shared by the hbm tests (no project imports besides hbm)."""

from __future__ import annotations

import numpy as np

import hbm

RPM = hbm.RPM_TO_RAD_S


def sdof_problem(harmonics=30, zeta=0.05, fm=0.1, fa=0.05, alpha=0.2, b=1.0,
                 condensation="loa", te=None, n_time=None):
    """Kahraman-Singh pair x'' + 2 zeta x' + k(t) f(x - e(t)) = F_m + F_a cos(w t).

    Unit mass, unit mean stiffness (w_n = 1 rad/s), one tooth so that the mesh
    frequency equals Omega; k(t) = 1 + alpha cos(Omega t).
    """
    system = hbm.LinearSystem(M=[[1.0]], C=[[2 * zeta]], K=[[0.0]])
    mesh = hbm.GearMesh(direction=[1.0], n_teeth=1, stiffness={0: 1.0, 1: alpha}, te=te or {},
                        backlash=b)
    exc = hbm.Excitation(1, constant={0: [fm], 1: [fa]})
    hs = hbm.HarmonicSet.build(1, harmonics, n_time=n_time)
    return hbm.HBMProblem(system, [mesh], exc, hs, condensation)


def random_modal_system(n=20, seed=0, zeta=0.03, kbar=2.0e3, n_gear=12):
    """Random (M, C, K, G) with the modal damping of eq. (17)-(19)."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, n))
    m = a @ a.T / n + np.eye(n)
    b = rng.standard_normal((n, n))
    k = 1e3 * (b @ b.T / n + 0.1 * np.eye(n))
    g = np.zeros(n)
    g[:n_gear] = rng.standard_normal(n_gear)
    g /= np.linalg.norm(g)
    import scipy.linalg as sla
    w2, phi = sla.eigh(k + kbar * np.outer(g, g), m)
    c = m @ phi @ np.diag(2 * zeta * np.sqrt(w2)) @ phi.T @ m            # eq. (19)
    return m, c, k, g



def random_mesh_problem(n: int, seed: int, zeta: float, n_gear: int, k1: float,
                        harmonics: int, kbar: float = 2.0e3) -> hbm.HBMProblem:
    """A random modal system (:func:`random_modal_system`) with one gear mesh of mean
    stiffness ``kbar`` and first harmonic ``k1`` (1 tooth, backlash 1e-3) along its gear
    direction, forced by 2 g + g cos, on ``harmonics`` harmonics."""
    m, c, k, g = random_modal_system(n=n, seed=seed, zeta=zeta, kbar=kbar, n_gear=n_gear)
    return hbm.HBMProblem(hbm.LinearSystem(m, c, k),
                          [hbm.GearMesh(g, 1, {0: kbar, 1: k1}, backlash=1e-3)],
                          hbm.Excitation(n, constant={0: 2.0 * g, 1: 1.0 * g}),
                          hbm.HarmonicSet.build(1, harmonics))

def gear_and_stiff_mode_problem():
    """A gear mode and a weakly coupled stiff mode (10 % modal damping, eq. 19),
    parametric mesh stiffness, one tooth; its branch over 0.3-1.6 rad/s has two folds."""
    import scipy.linalg as sla
    m, k, g = np.eye(2), np.array([[0.0, 0.0], [0.0, 100.0]]), np.array([1.0, 0.3])
    w2, phi = sla.eigh(k + np.outer(g, g), m)
    c = m @ phi @ np.diag(0.1 * np.sqrt(w2)) @ phi.T @ m
    return hbm.HBMProblem(hbm.LinearSystem(m, c, k),
                          [hbm.GearMesh(g, 1, {0: 1.0, 1: 0.2}, backlash=1.0)],
                          hbm.Excitation(2, constant={0: [0.1, 0.0], 1: [0.05, 0.0]}),
                          hbm.HarmonicSet.build(1, 20))


def neimark_sacker_problem(harmonics=20):
    """Two coupled modes through one gear mesh (one tooth, mesh frequency Omega, 30 %
    mesh-stiffness variation, 2 % modal damping, eq. 19): coupled modes 0.881 and
    1.966 rad/s, so the combination resonance Omega ~ w1 + w2 makes the periodic orbit
    lose stability by a complex pair of Floquet multipliers (Neimark–Sacker) over
    Omega = 2.77-2.92 rad/s; there the time response is quasi-periodic, with lines at
    the orders ~0.31 and ~0.69 (w1 / Omega, w2 / Omega) beside the mesh order 1."""
    import scipy.linalg as sla
    m, k, g = np.eye(2), np.array([[0.0, 0.0], [0.0, 3.0]]), np.array([1.0, 0.8])
    w2, phi = sla.eigh(k + np.outer(g, g), m)
    c = m @ phi @ np.diag(0.04 * np.sqrt(w2)) @ phi.T @ m
    return hbm.HBMProblem(hbm.LinearSystem(m, c, k),
                          [hbm.GearMesh(g, 1, {0: 1.0, 1: 0.3}, backlash=1.0)],
                          hbm.Excitation(2, constant={0: [0.1, 0.0], 1: [0.02, 0.0]}),
                          hbm.HarmonicSet.build(1, harmonics))


def orbit_departure(pb, pt, periods: int = 40) -> float:
    """Distance (energy norm of the modal state, relative) after ``periods`` periods of
    the time integration (scipy DOP853, rtol 1e-10, modal equations of
    hbm.post.time_response) started on the HBM state of ``pt``, from that state: ~0 on a
    stable orbit, O(1) when the integration leaves for another attractor."""
    from scipy.integrate import solve_ivp

    from hbm.post.time_response import equations, initial_state, modal_model

    mm = modal_model(pb, pt.rpm)
    fun = equations(mm)
    w = np.concatenate([np.sqrt(mm.w2), np.ones(mm.n_modes)])
    y0 = initial_state(pb, pt, mm)
    scale = np.linalg.norm(y0 * w)
    sol = solve_ivp(fun, (0.0, periods * mm.period), y0, method="DOP853", rtol=1e-10,
                    atol=1e-14 * scale / w)
    return float(np.linalg.norm((sol.y[:, -1] - y0) * w) / scale)
