"""The reference file of the pump time integrations and the error metric of
benchmarks/bench_converged.py (issue 13 item 4), on synthetic data (fast).

1. A reference is keyed by the scene, the ROM stage-cache key (and the SHA-256 of the
   ROM file) and the physics the HBM adds to the ROM: the loader returns what was
   written and refuses a file whose physics key differs, or whose ROM key differs
   unless the ROM file is the same; changing the torque changes the physics key only.
2. On a synthetic S-shaped branch (three sheets over 1200-1400 rpm, known std and
   Delta on each), the metric takes the sheet whose Delta is nearest to the
   reference's, whatever its std, and returns the relative std error exactly.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks import bench_converged as bc
from benchmarks import ti_reference as tr

ROOT = Path(__file__).resolve().parents[2]
PUMP = ROOT / "scenes" / "pump.toml"


def _record(rpm: float, coefficients: np.ndarray) -> dict:
    return {"rpm": rpm, "std": 12.5, "rms": 70.1, "p2p": 40.0, "contact": 1, "periods": 9,
            "seconds": 3.0, "n_rhs": 10, "state_change": 1e-9, "load_change": 1e-10,
            "converged": True, "accepted": True, "samples": 64, "n_modes": 4,
            "delta_coefficients": {"harmonics": coefficients.size,
                                   "re": tr._round(coefficients.real),
                                   "im": tr._round(coefficients.imag)},
            "start": {}, "hbm_solutions": [{"branch_index": 0, "branch_rpm": rpm,
                                            "stable": True, "std": 12.5, "distance": 0.0}],
            "attractor": 0}


def test_reference_refuses_another_rom_or_physics(tmp_path):
    key = tr.reference_key(PUMP, tmp_path / "cache")
    assert key["scene"] == "scenes/pump.toml"
    c = np.array([1e-5, 2e-6 - 1e-6j, 3e-7j])
    path = tmp_path / "ref.json"
    tr.write_reference(path, key, [_record(1500.0, c), _record(900.0, c)], {})
    ref = tr.load_reference(path, key)
    assert [r["rpm"] for r in ref["speeds"]] == [900.0, 1500.0]
    np.testing.assert_allclose(ref["speeds"][0]["coefficients"], c, rtol=1e-12)

    assert key["rom_sha256"] is None                      # no ROM in that cache
    with pytest.raises(tr.StaleReference, match="rom_key"):
        tr.load_reference(path, {**key, "rom_key": "0" * 64})
    # another ROM key: refused unless both name the same ROM file
    with_sha = {**key, "rom_sha256": "a" * 64}
    tr.write_reference(path, with_sha, [_record(900.0, c)], {})
    assert tr.load_reference(path, {**with_sha, "rom_key": "0" * 64})["speeds"][0]["rpm"] == 900
    with pytest.raises(tr.StaleReference, match="ROM file differs"):
        tr.load_reference(path, {**with_sha, "rom_key": "0" * 64, "rom_sha256": "b" * 64})
    with pytest.raises(tr.StaleReference, match="ROM file differs"):
        tr.load_reference(path, {**with_sha, "rom_key": "0" * 64, "rom_sha256": None})
    with pytest.raises(tr.StaleReference, match="physics_key"):
        tr.load_reference(path, {**key, "physics_key": "0" * 64})

    # a torque change is physics on top of the same ROM
    other = tmp_path / "pump.toml"
    other.write_text(PUMP.read_text().replace("torque_Nm = 3.29", "torque_Nm = 4.0"))
    k2 = tr.reference_key(other, tmp_path / "cache")
    assert k2["rom_key"] == key["rom_key"] and k2["physics_key"] != key["physics_key"]
    with pytest.raises(tr.StaleReference, match="scene"):
        tr.load_reference(path, k2)


def _write_rom(folder: Path, M, K, C, rows, n_gear: int) -> None:
    import h5py
    folder.mkdir(parents=True)
    with h5py.File(folder / "rom.h5", "w") as f:
        for name, a in (("M", M), ("K", K), ("C", C)):
            f[f"rom/{name}"] = a
        f["rom/gear_dofs"] = np.array([b"u"] * n_gear)
    with h5py.File(folder / "nodes.h5", "w") as f:
        f["basis_rows"] = rows


def test_rom_fingerprint_sees_the_dynamics_not_the_basis(tmp_path):
    """The fingerprint of a ROM whose component modes are mixed, reordered and
    sign-flipped (the same reduced space) equals the original's to round-off, and one
    of a ROM whose stiffness moved by 1e-6 does not: a reference stays valid across a
    change of the eigen-solver, not across a change of the model."""
    rng = np.random.default_rng(3)
    n, ng = 20, 4
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)
    B = rng.standard_normal((n, n))
    K = 1e7 * (B @ B.T + n * np.eye(n))
    C = 1e-4 * K + 2.0 * M
    rows = rng.standard_normal((6, n))
    S = np.eye(n)                                   # gear DOF stay physical
    Q, _ = np.linalg.qr(rng.standard_normal((n - ng, n - ng)))
    S[ng:, ng:] = Q[rng.permutation(n - ng)] * rng.choice([-1.0, 1.0], n - ng)
    S[ng:, :ng] = rng.standard_normal((n - ng, ng))  # and any static-mode shift
    roms = {"a": (M, K, C, rows), "b": (S.T @ M @ S, S.T @ K @ S, S.T @ C @ S, rows @ S),
            "c": (M, K * (1 + 1e-6), C, rows)}
    fp = {}
    for name, (m, k, c, r) in roms.items():
        _write_rom(tmp_path / "rom" / (name * 24), m, k, c, r, ng)
        fp[name] = tr.rom_fingerprint(tmp_path, name * 24)
    assert len(fp["a"]) == 2 * len(tr.FINGERPRINT_HZ) * tr.FINGERPRINT_PROJECTIONS
    assert tr.same_fingerprint(fp["a"], fp["b"])
    assert not tr.same_fingerprint(fp["a"], fp["c"])
    assert tr.rom_fingerprint(tmp_path, "d" * 24) is None
    key = {"scene": "s", "physics_key": "p", "rom_key": "a" * 24, "rom_sha256": "1" * 64,
           "rom_fingerprint": fp["a"]}
    tr.check_key(key, {**key, "rom_key": "b" * 24, "rom_sha256": "2" * 64,
                       "rom_fingerprint": fp["b"]})
    with pytest.raises(tr.StaleReference, match="ROM file differs"):
        tr.check_key(key, {**key, "rom_key": "c" * 24, "rom_sha256": "3" * 64,
                           "rom_fingerprint": fp["c"]})


def test_fourier_coefficients_of_samples():
    n, t = 64, np.arange(64) / 64
    c = np.array([0.3, 1 - 2j, 0, 0.25j])
    x = sum((ck * np.exp(2j * np.pi * k * t)).real for k, ck in enumerate(c))
    np.testing.assert_allclose(tr.fourier_coefficients(x, 4), c, atol=1e-14)
    with pytest.raises(ValueError, match="samples"):
        tr.fourier_coefficients(x[:7], 4)
    assert n == x.size


# ------------------------------------------------------------- synthetic branch
# s in [0, 3]: rpm 1000 -> 1400 (lower sheet), 1400 -> 1200 (unstable), 1200 -> 1600
def _rpm_of(s):
    s = np.asarray(s, float)
    return np.where(s <= 1, 1000 + 400 * s, np.where(s <= 2, 1400 - 200 * (s - 1),
                                                     1200 + 400 * (s - 2)))


def _s_on_piece(piece: int, rpm: float) -> float:
    return ((rpm - 1000) / 400, 1 + (1400 - rpm) / 200, 2 + (rpm - 1200) / 400)[piece]


def _std(s):
    return 10 + 20 * s


def _vector(s):
    return np.array([1e-5, (1 + s) * 1e-6 * np.exp(1j * s), 1e-7 * s])


S = np.linspace(0, 3, 91)
RPM = _rpm_of(S)


def _solver(rpm):
    def solve_from(i):
        s = _s_on_piece(min(int(S[i]), 2), rpm)
        return {"std": _std(s), "vector": _vector(s)}
    return solve_from


def test_pieces_of_the_synthetic_branch():
    pieces = tr.monotone_pieces(RPM)
    assert [(p[0], p[-1]) for p in pieces] == [(0, 30), (30, 60), (60, 90)]
    assert len(tr.crossing_starts(RPM, 1300.0)) == 3
    assert len(tr.crossing_starts(RPM, 1100.0)) == 1
    assert len(tr.crossing_starts(RPM, 1550.0)) == 1


def test_error_on_the_attractor_of_the_reference():
    # the reference lies on the upper sheet at 1300 rpm (s = 2.25, std 55 N), its std
    # 4e-4 below the sheet's, its Delta 1e-5 away from the sheet's
    s_up = _s_on_piece(2, 1300.0)
    ref_std = _std(s_up) / (1 + 4e-4)
    ref = {"rpm": 1300.0, "std": ref_std, "coefficients": _vector(s_up) * (1 + 1e-5)}
    sols = bc.branch_solutions(RPM, 1300.0, _solver(1300.0))
    assert len(sols) == 3
    row = bc.attractor_error(ref, sols)
    assert row["solutions"] == 3
    assert row["std"] == pytest.approx(55.0, rel=1e-14)
    assert row["err_std"] == pytest.approx(4e-4, rel=1e-9)
    assert S[row["branch_index"]] > 2                       # a point of the upper sheet
    # the middle sheet would give a smaller error here if picked by std: it is not
    ref_mid = {**ref, "std": _std(1.5) + 4.0}                # 44 N: 4 N from the middle
    assert bc.attractor_error(ref_mid, sols)["std"] == pytest.approx(55.0)

    s_hi = _s_on_piece(2, 1500.0)
    ref2 = {"rpm": 1500.0, "std": _std(s_hi) * (1 - 2e-3), "coefficients": _vector(s_hi)}
    row2 = bc.attractor_error(ref2, bc.branch_solutions(RPM, 1500.0, _solver(1500.0)))
    assert row2["err_std"] == pytest.approx(2e-3 / (1 - 2e-3), rel=1e-9)
    summ = bc.summarize([row, row2])
    assert summ["max_err_std"] == row2["err_std"] and summ["worst_rpm"] == 1500.0
    assert not summ["within_eps"]
    assert bc.summarize([row])["within_eps"]
    with pytest.raises(ValueError, match="no HBM solution"):
        bc.attractor_error(ref, [])


def test_remaining_drift_of_a_geometric_tail():
    changes = [1e-5 * 0.5 ** k for k in range(12)]
    # sum_{j>=1} c r^j = c r / (1 - r) = c for r = 1/2
    assert tr.remaining_drift(changes) == pytest.approx(changes[-1], rel=1e-9)
    assert tr.remaining_drift([1e-6, 2e-6, 4e-6]) == float("inf")
    assert tr.remaining_drift([1e-6, 5e-7]) == float("inf")        # too few periods


def test_uncertainty_of_a_reference():
    floor = [2e-5, 1e-7, 3e-7, 5e-8, 2e-7, 1e-7, 3e-8, 2.5e-7, 1e-7, 6e-8]
    assert 3e-7 <= tr.uncertainty(floor) < 1e-6           # at least the jitter of the last 8
    assert tr.uncertainty([1e-7] * 4 + [2e-7] * 4) == 2e-7   # no decrease: the jitter only
    tail = [1e-5 * 0.9 ** k for k in range(12)]
    assert tr.uncertainty(tail) == pytest.approx(tail[-1] * 9, rel=1e-9)   # r / (1 - r) = 9
    assert tr.settled({"converged": False, "load_changes": floor})
    assert not tr.settled({"converged": False, "load_changes": [1e-4] * 9})
    assert tr.settled({"converged": True, "load_changes": []})
