"""The fixed-interface problem on K, M in place (reduction.interface): the blocks inside,
K and M restored bit for bit afterwards, also after an error."""

import numpy as np
import pytest
import scipy.sparse as sp

from reduction import craig_bampton
from reduction.interface import interface_columns, interface_eliminated
from reduction.models import chain_dense, spring_chain

N = 120
IFACE = np.array([100, 3, 57, 20, 119, 60, 61, 40, 0, 41, 5, 90])


def _csr(A):
    ia, ja, va = A.getValuesCSR()
    return np.array(ia), np.array(ja), np.array(va)


def _dense(A):
    ia, ja, va = _csr(A)
    return sp.csr_matrix((va, ja, ia), shape=A.getSize()).toarray()


def test_blocks_inside_and_bitwise_restore():
    chain = spring_chain(N, IFACE)
    Md, Kd = chain_dense(N)
    before = [_csr(A) for A in (chain.K, chain.M)]
    ii = np.setdiff1d(np.arange(N), IFACE)
    with interface_eliminated(chain.K, chain.M, IFACE) as saved_K:
        K_t, M_t = _dense(chain.K), _dense(chain.M)
        # K̃ = K_ii on the interior, identity on the interface, no coupling; M̃: zero there
        np.testing.assert_array_equal(K_t[np.ix_(ii, ii)], Kd[np.ix_(ii, ii)])
        np.testing.assert_array_equal(M_t[np.ix_(ii, ii)], Md[np.ix_(ii, ii)])
        np.testing.assert_array_equal(K_t[IFACE][:, IFACE], np.eye(IFACE.size))
        np.testing.assert_array_equal(M_t[IFACE], 0.0)
        for A in (K_t, M_t):
            np.testing.assert_array_equal(A[np.ix_(ii, IFACE)], 0.0)
            np.testing.assert_array_equal(A[np.ix_(IFACE, ii)], 0.0)
        B = interface_columns(chain.K, IFACE, saved_K).getDenseArray()
        np.testing.assert_array_equal(B[ii], Kd[np.ix_(ii, IFACE)])   # K_ic
        np.testing.assert_array_equal(B[IFACE], 0.0)
    for A, ref in zip((chain.K, chain.M), before, strict=True):
        for a, b in zip(_csr(A), ref, strict=True):
            np.testing.assert_array_equal(a, b)  # same pattern, same bits


def test_restored_after_an_error():
    chain = spring_chain(N, IFACE)
    before = [_csr(A) for A in (chain.K, chain.M)]
    with pytest.raises(RuntimeError, match="inside"), \
            interface_eliminated(chain.K, chain.M, IFACE):
        assert np.count_nonzero(_csr(chain.M)[2] == 0.0) > 0
        raise RuntimeError("inside")
    for A, ref in zip((chain.K, chain.M), before, strict=True):
        for a, b in zip(_csr(A), ref, strict=True):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("factor", ["lu", "cholesky"])
def test_craig_bampton_leaves_k_and_m_unchanged(factor):
    """The reduction works on K, M in place: afterwards both are the caller's matrices
    bit for bit, and the projection (done after the restore) gives the exact Schur
    complement K_cc − K_ci K_ii⁻¹ K_ic."""
    chain = spring_chain(N, IFACE)
    _, Kd = chain_dense(N)
    before = [_csr(A) for A in (chain.K, chain.M)]
    cb = craig_bampton(chain.M, chain.K, IFACE, n_modes=8, factor=factor)
    for A, ref in zip((chain.K, chain.M), before, strict=True):
        for a, b in zip(_csr(A), ref, strict=True):
            np.testing.assert_array_equal(a, b)
    ii = np.setdiff1d(np.arange(N), IFACE)
    S = Kd[np.ix_(IFACE, IFACE)] - Kd[np.ix_(IFACE, ii)] @ np.linalg.solve(
        Kd[np.ix_(ii, ii)], Kd[np.ix_(ii, IFACE)])
    np.testing.assert_allclose(cb.K_r[:12, :12], S, rtol=0, atol=1e-10 * np.abs(S).max())
    T = cb.T.getDenseArray()
    np.testing.assert_array_equal(T[IFACE, :12], np.eye(12))   # identity on q_c
    np.testing.assert_array_equal(T[IFACE, 12:], 0.0)          # Φ vanishes there


def test_out_of_core_factor_gives_the_same_reduction(tmp_path, monkeypatch):
    """``out_of_core=True``: MUMPS factors with ICNTL(22) = 1 into $MUMPS_OOC_TMPDIR (its
    files are gone afterwards) and gives the in-core ROM; a bad folder is refused first."""
    chain = spring_chain(N, IFACE)
    ref = craig_bampton(chain.M, chain.K, IFACE, n_modes=10, factor="cholesky")
    monkeypatch.setenv("MUMPS_OOC_TMPDIR", str(tmp_path))
    ooc = craig_bampton(chain.M, chain.K, IFACE, n_modes=10, factor="cholesky",
                        out_of_core=True)
    assert ooc.factor_stats["out_of_core"] and not ref.factor_stats["out_of_core"]
    np.testing.assert_allclose(ooc.fixed_interface_hz, ref.fixed_interface_hz, rtol=1e-12)
    for a, b in ((ooc.K_r, ref.K_r), (ooc.M_r, ref.M_r)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-10 * np.abs(b).max())
    assert list(tmp_path.iterdir()) == []        # MUMPS removed its factor files
    monkeypatch.setenv("MUMPS_OOC_TMPDIR", str(tmp_path / "missing"))
    with pytest.raises(ValueError, match="MUMPS_OOC_TMPDIR"):
        craig_bampton(chain.M, chain.K, IFACE, n_modes=10, out_of_core=True)
