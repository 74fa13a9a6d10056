"""The reduced Newton system ``(Z^T H Z + delta I) p = rhs`` of the stagewise solver, assembled and
factorized in one of two forms.

``H`` is a sum of per-waypoint window Hessians (three consecutive blocks), per-block terms
(bounds' barrier), and the constant quadratic terms ``Q = D + R^T diag(g) R`` (``D`` banded in
the blocks; ``R`` a few dense rows: the lifted forms of J5, :mod:`forte.planning.terms.spectral`).

- **dense** (up to :data:`DENSE_VARIABLES` free variables; the lift at N = 41 has 380): the
  reduced matrix is formed in full (``Q``'s dense blocks included) and factorized by a dense
  Cholesky, ``(nr^3)/3`` flops, 0.1 ms for ``nr = 148``;
- **banded** (longer horizons): ``Z^T (H - R^T G R) Z`` is banded (three blocks of ``r`` columns
  each way, or ``D``'s block bandwidth when wider) and factorized by a banded Cholesky in
  ``O(nr b^2)``; the dense rows enter by the Woodbury identity with ``U = Z^T R^T``:
  ``(B + U G U^T)^-1 = B^-1 - B^-1 U S^-1 U^T B^-1``, ``S = G^-1 + U^T B^-1 U``.

Inertia. IPOPT's correction (``H + delta I`` until the reduced matrix is positive definite)
needs the test "positive definite". Dense: the Cholesky succeeds. Banded: by Haynsworth's
inertia additivity on ``[[B, U], [U^T, -G^-1]]``, with ``B`` positive definite (its Cholesky
succeeds) the number of negative eigenvalues of ``B + U G U^T`` is ``n_+(S) - n_+(G)``, so the
test is ``n_+(S) = n_+(G)`` with ``S`` nonsingular (eigenvalues of an ``L x L`` matrix).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from scipy import sparse
from scipy.linalg.lapack import dpotrf, dpotrs

from forte.validation import FloatArray

#: Up to this many free variables the reduced matrix is dense.
DENSE_VARIABLES = 1200


class ReducedSystem:
    """Index maps of one problem's reduced matrix and its factorization with inertia correction.

    Args:
        nr: size of the reduced matrix (blocks x r).
        window_entries: flat ``nr x nr`` index of every entry of the reduced window Hessians.
        block_entries: flat index of every entry of the per-block diagonal blocks.
        bandwidth: half bandwidth of the banded part (used when ``banded``).
        banded: the banded form (else dense).
    """

    def __init__(self, nr: int, window_entries: FloatArray, block_entries: FloatArray, bandwidth: int,
                 banded: bool) -> None:
        self.nr, self.banded, self.bw = nr, banded, bandwidth
        self.delta_last = 0.0
        if banded:
            self._window = self._band_index(window_entries)
            self._blocks = self._band_index(block_entries)
        else:
            self._window, self._blocks = (window_entries, None), (block_entries, None)

    def _band_index(self, flat: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Lower banded storage ``ab[i - j, j] = a[i, j]`` (``i >= j``) of the flat entries: their
        positions, and which entries they are (the upper ones are dropped)."""
        i, j = np.divmod(flat, self.nr)
        keep = np.flatnonzero(i >= j)
        if (i[keep] - j[keep] > self.bw).any():
            raise AssertionError("a window entry outside the band")
        return (i[keep] - j[keep]) * self.nr + j[keep], keep

    def assemble(self, window: FloatArray, blocks: FloatArray, quadratic: sparse.spmatrix | FloatArray
                 ) -> FloatArray:
        """The reduced matrix (dense ``nr x nr`` or lower banded ``(bw + 1) x nr``) from the reduced
        window Hessians, the diagonal blocks and ``Z^T D Z`` (dense: ``Z^T Q Z``)."""
        size = (self.bw + 1) * self.nr if self.banded else self.nr * self.nr
        pos, keep = self._window
        out = np.bincount(pos, window.ravel() if keep is None else window.ravel()[keep], minlength=size)
        pos, keep = self._blocks
        out += np.bincount(pos, blocks.ravel() if keep is None else blocks.ravel()[keep], minlength=size)
        if not self.banded:
            return out.reshape(self.nr, self.nr) + quadratic
        qc = sparse.coo_matrix(quadratic)
        low = qc.row >= qc.col
        out += np.bincount((qc.row[low] - qc.col[low]) * self.nr + qc.col[low], qc.data[low], minlength=size)
        return out.reshape(self.bw + 1, self.nr)

    def solve(self, M: FloatArray, rhs: FloatArray, U: FloatArray | None = None, g: FloatArray | None = None
              ) -> tuple[FloatArray, float]:
        """``(M + U diag(g) U^T + delta I)^-1 rhs`` with the smallest ``delta`` of IPOPT's sequence
        (1e-4, x100 first, then x8 from a third of the last one) that makes it positive definite."""
        delta = 0.0
        for attempt in range(40):
            try:
                x = self._factor_solve(M, rhs, delta, U, g)
                if delta:
                    self.delta_last = delta
                return x, delta
            except np.linalg.LinAlgError:
                if attempt == 0:
                    delta = 1e-4 if self.delta_last == 0 else max(1e-20, self.delta_last / 3)
                else:
                    delta *= 100 if self.delta_last == 0 else 8
        raise np.linalg.LinAlgError("the reduced Hessian stays indefinite")

    def _factor_solve(self, M: FloatArray, rhs: FloatArray, delta: float, U: FloatArray | None,
                      g: FloatArray | None) -> FloatArray:
        if not self.banded:
            A = M.copy()
            if delta:
                A.flat[:: self.nr + 1] += delta
            c, info = dpotrf(A, lower=1, clean=0, overwrite_a=1)  # LAPACK directly: the wrappers cost more
            if info != 0:
                raise np.linalg.LinAlgError("not positive definite")
            return dpotrs(c, rhs, lower=1)[0]
        ab = M.copy()
        ab[0] += delta
        cb = sla.cholesky_banded(ab, lower=True, check_finite=False)
        if U is None or not U.size:
            return sla.cho_solve_banded((cb, True), rhs, check_finite=False)
        Y = sla.cho_solve_banded((cb, True), np.column_stack([rhs, U]), check_finite=False)
        S = np.diag(1.0 / g) + U.T @ Y[:, 1:]
        eig = np.linalg.eigvalsh(S)
        if (eig > 0).sum() != (g > 0).sum() or np.abs(eig).min() <= 1e-12 * np.abs(eig).max():
            raise np.linalg.LinAlgError("not positive definite")
        return Y[:, 0] - Y[:, 1:] @ np.linalg.solve(S, U.T @ Y[:, 0])

    def reset(self) -> None:
        self.delta_last = 0.0
