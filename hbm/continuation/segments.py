"""The segments of a growing branch near a point, without scanning the whole branch.

The walk-back and closed-loop tests (:mod:`hbm.continuation.revisits`) ask, at every
accepted point, which earlier segments ``(i, i + 1)`` of the branch lie closer than a
fraction of the last chord to the new point. Scanning every segment costs ``O(n)`` per
point (on a 12 000-point lumped branch the scan took most of the time of a point).
:class:`SegmentIndex` keeps bounding balls over blocks of consecutive segments, a binary
hierarchy (leaves of :data:`LEAF` segments, each level twice as long) grown as points
are appended and cut when the branch is truncated; a query descends from the longest
blocks and drops every block whose ball lies farther than the radius, so on a branch
that moves on (the speed advancing) it visits ``O(log n)`` blocks and a few leaves.
This is the bounding-volume hierarchy of collision detection (a ball tree built
along the curve, as the "sphere trees" of swept curves), exact by construction: a
dropped block holds no segment closer than the radius, with a margin above the
round-off of the distance (:func:`segment_gaps`), and the segments kept are measured by
the very same floating-point operations as a scan of the whole branch. The decisions of
the tests are therefore the same, bit for bit (tests/test_hbm_segments.py).
"""

from __future__ import annotations

import numpy as np

__all__ = ["LEAF", "MARGIN", "SegmentIndex", "pair_gaps", "segment_gaps"]

#: Segments per leaf block of the hierarchy.
LEAF = 16
#: Relative margin of the pruning bound (of the norms of the point and of the block's
#: ball): far above the round-off of a computed segment distance (a few ``eps`` of those
#: norms times the dimension's square root), far below the distances tested (a tenth of a
#: chord of a continuation step).
MARGIN = 1e-9


def segment_gaps(ys: np.ndarray, y: np.ndarray,
                 skip: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Distance of ``y`` to every segment ``(i, i + 1)`` of the polyline ``ys`` (inf where
    ``skip`` is True) and the nearest point (foot) of each: ``(distances, feet)``.

    Row by row the same operations whatever the number of rows: the distances of a few
    segments gathered from a polyline are those of a scan of the whole polyline, bitwise.
    """
    return pair_gaps(ys[:-1], ys[1:], y, skip)


def pair_gaps(a: np.ndarray, b: np.ndarray, y: np.ndarray,
              skip: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`segment_gaps` of the segments ``(a[k], b[k])`` (rows gathered from a polyline)."""
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", y - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab),
                                                               1e-300), 0.0, 1.0)
    foot = a + t[:, None] * ab
    d = np.linalg.norm(foot - y, axis=1)
    if skip is not None:
        d[skip[:d.size]] = np.inf
    return d, foot


class SegmentIndex:
    """Bounding balls over the segments of a polyline that grows at its end.

    Level ``l`` holds the balls of the blocks of ``LEAF * 2**l`` consecutive segments
    whose points all exist (block ``m``: segments ``[m B, (m + 1) B)``, points ``m B`` to
    ``(m + 1) B``). A leaf's ball is centred on the mean of its points, a parent's on the
    midpoint of its children's centres and encloses both children's balls.
    """

    def __init__(self) -> None:
        self.centres: list[list[np.ndarray]] = []   # per level, per block
        self.radii: list[list[float]] = []
        self.n_points = 0

    def grow(self, ys: np.ndarray, n: int) -> None:
        """Points ``0 .. n - 1`` of ``ys`` are in place (one more than before, or the
        first ``n`` of a branch rebuilt): add the blocks they complete."""
        for k in range(self.n_points + 1, n + 1):
            self.n_points = k
            last = k - 1                     # the newest point
            if last == 0 or last % LEAF:
                continue
            m = last // LEAF - 1             # the leaf ending at this point
            pts = ys[m * LEAF:last + 1]
            c = pts.mean(axis=0)
            r = float(np.max(np.linalg.norm(pts - c, axis=1)))
            self._add(0, m, c, r)
            level = 0
            while m % 2 == 1:                # the right child completes its parent
                left, right = m - 1, m
                c1, c2 = self.centres[level][left], self.centres[level][right]
                r1, r2 = self.radii[level][left], self.radii[level][right]
                c = 0.5 * (c1 + c2)
                r = max(float(np.linalg.norm(c - c1)) + r1, float(np.linalg.norm(c - c2)) + r2)
                level, m = level + 1, m // 2
                self._add(level, m, c, r)

    def _add(self, level: int, m: int, c: np.ndarray, r: float) -> None:
        if level == len(self.centres):
            self.centres.append([])
            self.radii.append([])
        assert len(self.centres[level]) == m
        self.centres[level].append(c)
        self.radii[level].append(r)

    def truncate(self, n: int) -> None:
        """Keep the first ``n`` points: drop the blocks that reach past them."""
        self.n_points = min(self.n_points, n)
        for level in range(len(self.centres)):
            keep = max(n - 1, 0) // (LEAF << level)
            del self.centres[level][keep:]
            del self.radii[level][keep:]

    def near(self, y: np.ndarray, radius: float, upto: int) -> np.ndarray:
        """Indices (ascending) of the segments ``i < upto`` that may lie closer than
        ``radius`` to ``y``: a superset of those whose :func:`segment_gaps` distance is
        below ``radius``, the far blocks dropped by the bound ``|y - c| - r``."""
        yn = float(np.linalg.norm(y))
        out: list[np.ndarray] = []
        s = 0
        for level in range(len(self.centres) - 1, -1, -1):
            size = LEAF << level
            while s % size == 0 and s + size <= upto and s // size < len(self.radii[level]):
                self._visit(level, s // size, y, yn, radius, out)
                s += size
        if s < upto:
            out.append(np.arange(s, upto))
        return np.concatenate(out) if out else np.zeros(0, dtype=np.intp)

    def _visit(self, level: int, m: int, y: np.ndarray, yn: float, radius: float,
               out: list[np.ndarray]) -> None:
        c, r = self.centres[level][m], self.radii[level][m]
        gap = float(np.linalg.norm(y - c)) - r
        if gap > radius + MARGIN * (yn + float(np.linalg.norm(c)) + r + 1.0):
            return
        if level == 0:
            out.append(np.arange(m * LEAF, (m + 1) * LEAF))
            return
        self._visit(level - 1, 2 * m, y, yn, radius, out)
        self._visit(level - 1, 2 * m + 1, y, yn, radius, out)
