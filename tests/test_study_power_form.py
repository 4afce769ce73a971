"""The ERP's quadratic form by the pivoted Cholesky factor of the radiation matrix
(study.outputs.acoustics.PowerForm): the powers equal W's own products to round-off for
a full-rank and a rank-deficient W, and an indefinite W keeps the plain product."""

import numpy as np
import pytest

from study.outputs.acoustics import PowerForm, erp_harmonics


@pytest.mark.parametrize("n, rank", [(60, 60), (60, 23), (30, 1)])
def test_the_factor_gives_the_powers_of_w(n, rank):
    rng = np.random.default_rng(n + rank)
    a = rng.standard_normal((n, rank))
    w = a @ a.T
    form = PowerForm(w)
    assert form.factor is not None and form.factor[0].shape == (rank, rank)
    q = rng.standard_normal((n, 9)) + 1j * rng.standard_normal((n, 9))
    omega = np.linspace(100.0, 900.0, 9)
    ref = erp_harmonics(w, q, omega)
    assert np.max(np.abs(erp_harmonics(form, q, omega) - ref)) < 1e-13 * np.max(ref)
    x = q.real.copy()
    assert np.max(np.abs(form(x) - np.einsum("ik,ik->k", x, w @ x))) < 1e-13 * np.max(
        np.abs(np.einsum("ik,ik->k", x, w @ x)))


def test_an_indefinite_matrix_keeps_the_plain_product():
    w = np.diag([1.0, -1.0, 2.0])
    form = PowerForm(w)
    assert form.factor is None
    assert np.array_equal(form(np.eye(3)), [1.0, -1.0, 2.0])
