"""The verdicts in doubt, checked on a richer harmonic set: what changed, in results.h5
``/verdict_checks`` and report.md (docs/theory.md §11, "Verdicts on a richer set";
:mod:`hbm.stability.recheck`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hbm.stability import KINDS
from hbm.stability.recheck import VerdictCheck

__all__ = ["VerdictChecks", "read_verdict_checks", "verdict_check_lines"]

#: kind code written for a point whose orbit has no counterpart on the richer set
NO_ORBIT_KIND = KINDS.index("fold")


@dataclass
class VerdictChecks:
    """The rechecked points of a branch and what they were before.

    Attributes
    ----------
    mesh_harmonics, n_unknowns
        The richer set (mesh harmonics) and its unknowns.
    checks
        One :class:`hbm.stability.recheck.VerdictCheck` per rechecked point.
    stable_before, max_real_before, kind_before
        The points' verdicts, largest real parts (1/s) and kind codes on the run's own set.
    seconds
        What the checks cost (s).
    """

    mesh_harmonics: int
    n_unknowns: int
    checks: list[VerdictCheck]
    stable_before: np.ndarray
    max_real_before: np.ndarray
    kind_before: np.ndarray
    seconds: float

    @classmethod
    def apply_to(cls, branch, mesh_harmonics: int, n_unknowns: int,
                 checks: list[VerdictCheck], seconds: float) -> VerdictChecks:
        """Record the checked points' verdicts on the run's own set, then write the checked
        ones into the branch (``stable``, ``floquet_kind``, ``floquet_max_real``; the
        exponent is NaN where no orbit was found)."""
        idx = np.array([c.index for c in checks], dtype=np.int64)
        out = cls(mesh_harmonics, n_unknowns, checks,
                  np.asarray(branch.stable, dtype=bool)[idx].copy(),
                  np.asarray(branch.floquet_max_real, dtype=float)[idx].copy(),
                  np.asarray(branch.floquet_kind)[idx].copy(), seconds)
        out._write_into(branch)
        return out

    @property
    def stable_after(self) -> np.ndarray:
        """Verdict of each point after the check: the richer set's on the same orbit,
        not stable where the richer set has no orbit near it."""
        return np.array([c.stable and c.same_orbit for c in self.checks], dtype=bool)

    @property
    def n_changed(self) -> int:
        """Points whose stability changed."""
        return int(np.sum(self.stable_after != self.stable_before))

    def _write_into(self, branch) -> None:
        for c, ok in zip(self.checks, self.stable_after, strict=True):
            branch.stable[c.index] = ok
            if c.same_orbit:
                branch.floquet_kind[c.index] = c.kind
                branch.floquet_max_real[c.index] = c.max_real
            elif branch.floquet_kind[c.index] == 0:
                branch.floquet_kind[c.index] = NO_ORBIT_KIND
                branch.floquet_max_real[c.index] = np.nan

    def write_group(self, f) -> None:
        """``/verdict_checks`` of results.h5 (docs/results-format.md)."""
        g = f.create_group("verdict_checks")
        g.attrs["mesh_harmonics"] = int(self.mesh_harmonics)
        g.attrs["n_unknowns"] = int(self.n_unknowns)
        g.attrs["seconds"] = float(self.seconds)
        c = self.checks
        g["index"] = np.array([x.index for x in c], dtype=np.int64)
        g["rpm"] = np.array([x.rpm for x in c], dtype=float)
        g["stable_before"] = np.asarray(self.stable_before, dtype=bool)
        g["max_real_before"] = np.asarray(self.max_real_before, dtype=float)
        g["kind_before"] = np.asarray(self.kind_before, dtype=np.int64)
        g["stable"] = self.stable_after
        g["max_real"] = np.array([x.max_real for x in c], dtype=float)
        g["change"] = np.array([x.change for x in c], dtype=float)
        g["same_orbit"] = np.array([x.same_orbit for x in c], dtype=bool)
        g["max_real"].attrs["unit"] = g["max_real_before"].attrs["unit"] = "1/s"


def read_verdict_checks(f) -> VerdictChecks | None:
    """The ``/verdict_checks`` group of an open results.h5, None when absent."""
    if "verdict_checks" not in f:
        return None
    g = f["verdict_checks"]
    checks = [VerdictCheck(int(i), float(r), bool(s), -1, float(m), float(ch), bool(o))
              for i, r, s, m, ch, o in zip(g["index"][:], g["rpm"][:], g["stable"][:],
                                           g["max_real"][:], g["change"][:],
                                           g["same_orbit"][:], strict=True)]
    return VerdictChecks(int(g.attrs["mesh_harmonics"]), int(g.attrs["n_unknowns"]), checks,
                         g["stable_before"][:], g["max_real_before"][:], g["kind_before"][:],
                         float(g.attrs["seconds"]))


def _rpms(r: list[float]) -> str:
    return ", ".join(f"{x:.3f}" for x in r[:8]) + (f" (+{len(r) - 8})" if len(r) > 8 else "")


def verdict_check_lines(v: VerdictChecks | None, own_harmonics: int) -> list[str]:
    """Report lines of the verdict checks."""
    if v is None or not v.checks:
        return []
    before, after = v.stable_before, v.stable_after
    same = np.array([c.same_orbit for c in v.checks])
    rpm = np.array([c.rpm for c in v.checks])
    lost = list(rpm[before & ~after & same])
    gone = list(rpm[before & ~same])
    won = list(rpm[~before & after])
    out = [f"- verdicts in doubt checked with {v.mesh_harmonics} instead of {own_harmonics} "
           f"mesh harmonics ({len(v.checks)} points in and next to the near-grazing tangles "
           f"or flagged, {v.seconds:.0f} s): {v.n_changed} changed, the richer set's "
           "verdict written (`/verdict_checks`; docs/theory.md §11, verdicts on a richer set)"]
    if lost:
        out.append(f"  - **stable → unstable** at {_rpms(lost)} rpm: the better resolved orbit "
                   "is unstable")
    if gone:
        out.append(f"  - **stable → no orbit** at {_rpms(gone)} rpm: the richer set has no "
                   "orbit near it (an artefact of the harmonic set; the machine is not there)")
    if won:
        out.append(f"  - unstable → stable at {_rpms(won)} rpm")
    return out
