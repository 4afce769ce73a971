"""Craig–Bampton on a spring–mass chain, checked against dense SciPy solutions."""

import math

import numpy as np
import pytest
import scipy.linalg as sla
from petsc4py import PETSc

from reduction import build_rom, craig_bampton, cutoff_from_speed, reconstruct
from reduction.models import chain_dense, spring_chain
from reduction.validate import CHECK_MARGIN, compare, modes_to_check, validate_to

N = 200
IFACE = np.array([150, 3, 77, 20, 199, 100, 101, 40, 60, 61, 5, 130])


@pytest.fixture(scope="module")
def chain():
    return spring_chain(N, IFACE)


@pytest.fixture(scope="module")
def dense():
    return chain_dense(N)


def _interior_hz(dense):
    M, K = dense
    ii = np.setdiff1d(np.arange(N), IFACE)
    lam = sla.eigh(K[np.ix_(ii, ii)], M[np.ix_(ii, ii)], eigvals_only=True)
    return np.sqrt(lam) / (2 * math.pi)


def test_fixed_interface_modes_match_dense(chain, dense):
    cb = craig_bampton(chain.M, chain.K, IFACE, n_modes=30)
    ref = _interior_hz(dense)[:30]
    assert np.max(np.abs(cb.fixed_interface_hz - ref) / ref) < 1e-9
    # mass-normalised Φ: Φᵀ M_ii Φ = I, Φᵀ K_ii Φ = diag(ω²), Φ ⟂_K Ψ
    lam = (2 * math.pi * cb.fixed_interface_hz) ** 2
    np.testing.assert_allclose(cb.M_r[12:, 12:], np.eye(30), atol=1e-10)
    np.testing.assert_allclose(cb.K_r[12:, 12:], np.diag(lam), rtol=1e-9, atol=1e-9 * lam.max())
    assert np.abs(cb.K_r[12:, :12]).max() < 1e-9 * np.abs(cb.K_r).max()
    assert cb.psi_residual < 1e-12


def test_cholesky_factor_gives_the_same_reduction(chain, dense):
    """rom.factorization = 'cholesky' (the default): MUMPS LDLᵀ of K_ii, one factorisation
    (also with the cut-off restarts); modes, Schur complement and ROM equal the LU ones and
    SciPy's."""
    PETSc.Log.begin()
    ev = PETSc.Log.Event("MatCholFctrNum")
    before = ev.getPerfInfo()["count"]
    ch = craig_bampton(chain.M, chain.K, IFACE, f_cut_hz=200.0)
    assert ev.getPerfInfo()["count"] - before == 1
    lu = craig_bampton(chain.M, chain.K, IFACE, f_cut_hz=200.0, factor="lu")
    ref = _interior_hz(dense)
    assert ch.n_cm == lu.n_cm == np.count_nonzero(ref <= 200.0)
    np.testing.assert_allclose(ch.fixed_interface_hz, ref[: ch.n_cm], rtol=1e-9)
    assert ch.psi_residual < 1e-12
    for a, b in ((ch.K_r, lu.K_r), (ch.M_r, lu.M_r)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-10 * np.abs(b).max())
    with pytest.raises(ValueError, match="factor"):
        craig_bampton(chain.M, chain.K, IFACE, n_modes=5, factor="qr")
    with pytest.raises(ValueError, match="blr_tol"):
        craig_bampton(chain.M, chain.K, IFACE, n_modes=5, blr_tol=-1.0)


def test_static_modes_give_schur_complement(chain, dense):
    # K_r restricted to q_c is the exact static condensation K_cc − K_ci K_ii⁻¹ K_ic
    cb = craig_bampton(chain.M, chain.K, IFACE, n_modes=5)
    _, K = dense
    ii = np.setdiff1d(np.arange(N), IFACE)
    S = K[np.ix_(IFACE, IFACE)] - K[np.ix_(IFACE, ii)] @ np.linalg.solve(
        K[np.ix_(ii, ii)], K[np.ix_(ii, IFACE)]
    )
    np.testing.assert_allclose(cb.K_r[:12, :12], S, rtol=1e-10, atol=1e-10 * np.abs(S).max())


def test_cutoff_keeps_all_modes_below_with_one_factorisation(chain, dense):
    PETSc.Log.begin()
    ev = PETSc.Log.Event("MatLUFactorNum")
    before = ev.getPerfInfo()["count"]
    f_cut = 200.0  # needs ~80 modes: the eigensolve is restarted with a larger space
    cb = craig_bampton(chain.M, chain.K, IFACE, f_cut_hz=f_cut, factor="lu")
    assert ev.getPerfInfo()["count"] - before == 1
    ref = _interior_hz(dense)
    assert cb.n_cm == np.count_nonzero(ref <= f_cut)
    assert cb.n_cm > 32
    np.testing.assert_allclose(cb.fixed_interface_hz, ref[: cb.n_cm], rtol=1e-9)


def test_rom_converges_from_above(chain, dense):
    M, K = dense
    full = np.sqrt(sla.eigh(K, M, eigvals_only=True)) / (2 * math.pi)
    errs = []
    for n_cm in (5, 20, 80):
        cb = craig_bampton(chain.M, chain.K, IFACE, n_modes=n_cm)
        rom_hz = np.sqrt(sla.eigh(cb.K_r, cb.M_r, eigvals_only=True)) / (2 * math.pi)
        # Rayleigh–Ritz: every ROM frequency bounds the full one from above
        assert np.all(rom_hz >= full[: rom_hz.size] * (1 - 1e-10))
        errs.append(compare(full[:15], rom_hz[:15], 1e-3).relative_error)
    errs = np.array(errs)
    assert np.all(errs[1] <= errs[0] + 1e-12) and np.all(errs[2] <= errs[1] + 1e-12)
    assert errs[2].max() < 1e-3 < errs[0].max()


def test_reconstruct_static_interface_load(chain, dense):
    # A load on interface DOF only: the CB solution T K_r⁻¹ Tᵀ f is the exact static one.
    M, K = dense
    cb = craig_bampton(chain.M, chain.K, IFACE, n_modes=10)
    f = np.zeros(N)
    f[IFACE] = np.linspace(-1.0, 2.0, 12) * 1e3
    u_full = np.linalg.solve(K, f)
    f_r = np.concatenate([f[IFACE], np.zeros(cb.n_cm)])  # Φ vanishes on the interface
    q = np.linalg.solve(cb.K_r, f_r)
    np.testing.assert_allclose(q[12:], 0.0, atol=1e-9 * np.abs(q).max())
    u = reconstruct(cb.T, q).getArray()
    np.testing.assert_allclose(u, u_full, rtol=1e-9, atol=1e-10 * np.abs(u_full).max())
    re, im = reconstruct(cb.T, q * (1 - 2j))
    np.testing.assert_allclose(re.getArray(), u_full, rtol=1e-9, atol=1e-10 * abs(u_full).max())
    np.testing.assert_allclose(im.getArray(), -2 * u_full, rtol=1e-9,
                               atol=2e-10 * abs(u_full).max())


def test_build_rom_orders_gear_dof_first(chain):
    cb = craig_bampton(chain.M, chain.K, IFACE, n_modes=8)
    G = np.zeros(12)
    G[0], G[1] = 1.0, -1.0
    rom = build_rom(cb, G, km_mean=5e6)
    assert rom.gear_dof_names[:3] == ("u1", "u2", "u3") and rom.n_r == 20
    assert rom.G.shape == (20, 1) and rom.n_meshes == 1
    assert np.all(rom.G[12:] == 0) and rom.G[0, 0] == 1.0
    # T's first column is the unit interface displacement of IFACE[0]
    col = reconstruct(cb.T, np.eye(20)[0]).getArray()
    assert col[IFACE[0]] == 1.0 and np.all(col[IFACE[1:]] == 0.0)


def test_check_up_to_a_frequency_compares_every_mode_below_it(chain, dense):
    """validate_to compares the full model's modes (known here from the dense coupled
    eigenproblem) up to f_check and stops just above it. The largest error up to f_check
    falls as the cut-off rises (measured on this chain: 1.8e-2, 3.5e-3, 7.4e-4 at 1.5, 2
    and 3 f_check, about (f_check / f_cut)³): 3 f_check (rom.cutoff_factor's default) passes
    1e-3, 2 f_check does not."""
    M, K = dense
    G = np.zeros(12)
    G[0], G[1] = 1.0, -1.0
    km = 5e6
    Kc = K.copy()
    Kc[np.ix_(IFACE[:2], IFACE[:2])] += km * np.array([[1.0, -1.0], [-1.0, 1.0]])
    full = np.sqrt(sla.eigh(Kc, M, eigvals_only=True)) / (2 * math.pi)
    f_check = 60.0
    cb = craig_bampton(chain.M, chain.K, IFACE, f_cut_hz=3 * f_check)
    rom = build_rom(cb, G, km)
    n_rom = np.count_nonzero(rom.frequencies_hz <= f_check)
    assert modes_to_check(rom.frequencies_hz, f_check) == n_rom + CHECK_MARGIN
    v = validate_to(rom, chain.M, chain.K, IFACE, G, km, f_check)
    n = v.full_hz.size
    np.testing.assert_allclose(v.full_hz, full[:n], rtol=1e-9)
    # every full mode below f_check is compared, and only CHECK_MARGIN beyond
    assert v.full_hz[-1] >= f_check > full[np.count_nonzero(full <= f_check) - 1]
    assert n == np.count_nonzero(full <= f_check) + CHECK_MARGIN
    assert v.relative_error.max() < 1e-3 and v.validity_hz == v.full_hz[-1] >= f_check
    cb2 = craig_bampton(chain.M, chain.K, IFACE, f_cut_hz=2 * f_check)
    v2 = validate_to(build_rom(cb2, G, km), chain.M, chain.K, IFACE, G, km, f_check)
    assert 1e-3 < v2.relative_error.max() < 1e-2 and v2.validity_hz < f_check
    assert v2.relative_error.max() > 3 * v.relative_error.max()
    # margins and bounds
    assert modes_to_check([10.0, 20.0, 30.0], 25.0) == 3
    assert modes_to_check([10.0, 20.0, 30.0, 40.0, 50.0], 5.0, margin=1) == 1
    with pytest.raises(ValueError, match="f_check"):
        modes_to_check([10.0], 0.0)


def test_cutoff_from_speed():
    # H_3Z of a 76-tooth gear at 6000 rpm: 3 · 76 · 100 Hz = 22.8 kHz, × 1.5
    assert cutoff_from_speed(6000.0, 76, 3, 1.5) == pytest.approx(1.5 * 3 * 76 * 6000 / 60)
    with pytest.raises(ValueError, match="safety"):
        cutoff_from_speed(6000.0, 76, 3, 0.5)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"n_modes": 0}, "n_modes"),
        ({"n_modes": 5, "f_cut_hz": 10.0}, "exactly one"),
        ({"f_cut_hz": -1.0}, "f_cut_hz"),
        ({"n_modes": 5, "interface_dofs": [1, 1, 2]}, "distinct"),
        ({"n_modes": 5, "interface_dofs": [0, N]}, "interface_dofs"),
    ],
)
def test_bad_input(chain, kwargs, field):
    kw = {"interface_dofs": IFACE} | kwargs
    with pytest.raises(ValueError, match=field):
        craig_bampton(chain.M, chain.K, **kw)


def test_cutoff_below_first_mode_rejected(chain):
    with pytest.raises(ValueError, match="f_cut_hz"):
        craig_bampton(chain.M, chain.K, IFACE, f_cut_hz=1.0)


def test_cutoff_choice_is_logged(chain, caplog):
    with caplog.at_level("INFO", logger="reduction.craig_bampton"):
        cb = craig_bampton(chain.M, chain.K, IFACE, f_cut_hz=120.0)
    assert f"n_CM = {cb.n_cm} fixed-interface modes below f_cut = 120 Hz" in caplog.text


def test_basis_read_back_by_row_keys(chain, tmp_path):
    """A basis saved with row keys is read onto another numbering: each row comes back
    at the position of its key, also across chunk boundaries; unknown keys are refused."""
    import h5py

    from reduction import load_basis, save_rom
    from reduction.io import _rows_by_key

    cb = craig_bampton(chain.M, chain.K, IFACE, n_modes=6)
    rom = build_rom(cb, np.eye(12)[1] - np.eye(12)[7], 5e6)
    rng = np.random.default_rng(3)
    keys = rng.permutation(10 * N)[:N]               # unique, not contiguous
    path = tmp_path / "rom.h5"
    save_rom(path, rom, row_keys=keys)
    ref = cb.T.getDenseArray().copy()
    other = rng.permutation(N)                       # the new partition's row order
    T = load_basis(path, row_keys=keys[other])
    np.testing.assert_array_equal(T.getDenseArray(), ref[other])
    with h5py.File(path, "r") as f:
        np.testing.assert_array_equal(f["rom/row_keys"][()], keys)
        got = _rows_by_key(f["rom/basis"], keys, keys[other], N, chunk=7)
    np.testing.assert_array_equal(got, ref[other])
    with pytest.raises(ValueError, match="row_keys"):
        load_basis(path, row_keys=np.arange(N) + 10 * N)
    with pytest.raises(ValueError, match="row_keys.shape"):
        save_rom(tmp_path / "bad.h5", rom, row_keys=keys[:-1])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rom.h5"]  # no temp file left
