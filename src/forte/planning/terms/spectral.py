"""The spectral base term J5 and the sparse forms the optimizer solves it in.

Per base coordinate ``b`` (N samples of x, y or yaw), with the orthonormal DCT-II ``C``
(``C b = scipy.fft.dct(b, norm='ortho')``)::

    J5(b) = 1/2 sum_{l in H} gamma_l bhat_l^2 = 1/2 b^T P b,    P = C^T diag(gamma) C

(``gamma_l = 0`` off the high set ``H``). ``P`` is dense: as a Hessian block it couples every
base sample with every other, and IPOPT's factorization of the KKT matrix grows with ``N^2`` and
beyond (``benchmarks/bench_scaling.py``). A :class:`SpectralForm` writes ``P`` as

    P = B + R^T diag(g) R,        B banded, R a few dense rows,

which the optimizer solves sparsely by lifting ``z = R b`` as variables (``z - R b = 0``):
``1/2 b^T P b = 1/2 (b^T B b + z^T diag(g) z)`` on those rows. The forms:

- ``dense``: ``B = P``, no rows (the formula as written);
- ``lifted`` (exact): when ``gamma`` is one constant ``g0`` over ``H`` (the paper-demo set,
  ``power = 0``), ``P = g0 C_H^T C_H = g0 (I - C_L^T C_L)`` (``C`` orthonormal, ``L`` the low
  set): ``B = g0 I`` with ``|L|`` rows of gain ``-g0``, or ``B = 0`` with ``|H|`` rows, whichever
  set is smaller. Exact to rounding;
- ``banded`` (an alternative weighting, not the formula): the DCT-II diagonalizes the Neumann
  Laplacian ``Lap = D^T D`` (``D`` the forward difference), ``C Lap C^T = diag(lambda)``,
  ``lambda_l = 4 sin^2(pi l / 2N)``, so ``gamma_l = p(kappa_l)`` for a polynomial ``p`` of
  degree ``m`` in the discrete squared wavenumber ``kappa_l = (N/pi)^2 lambda_l`` (which tends to
  ``l^2`` as N grows) gives ``C^T diag(p(kappa)) C = p((N/pi)^2 Lap)``, banded with ``m``
  off-diagonals. Zero weight below the cutoff is the exact correction ``-p(kappa_L)`` on the
  low rows. :func:`banded_weights` defines the cutoff and the weights in wavenumbers ``l``
  (cosine ``l`` has ``l/2`` periods over the horizon: ``l / (2T)`` Hz for a horizon of ``T = N dt``
  seconds) anchored at a reference horizon, so ``|L|`` and the weight of a given frequency stay
  fixed as N grows (resolution-independent); see there how it compares with the authors' ramp.

The authors' ramped ``gamma`` (power 2 over ``l/(N-1) > c``) is not constant over ``H`` and not
a polynomial in ``lambda``: it has no exact sparse form, so :func:`spectral_form` keeps it dense
(``auto`` up to :data:`DENSE_MAX_WAYPOINTS` waypoints) and offers the banded alternative above.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import sparse

from forte.exceptions import InvalidInputError
from forte.settings import DCT_FORMS
from forte.validation import FloatArray

#: ``auto`` keeps a weighting without an exact sparse form dense up to this horizon (the authors'
#: lift, 41, and the example tasks, up to 61, plan with the formula), banded beyond (the dense block
#: costs ~20 % more per iteration at N = 100, ~4x at N = 400: benchmarks/bench_scaling.py).
DENSE_MAX_WAYPOINTS = 64


def dct_matrix(n: int) -> FloatArray:
    """Orthonormal DCT-II matrix ``C`` (``C @ x`` equals ``scipy.fft.dct(x, norm='ortho')``)."""
    k = np.arange(n)[:, None]
    i = np.arange(n)[None, :]
    C = np.cos(np.pi * (2 * i + 1) * k / (2 * n)) * np.sqrt(2.0 / n)
    C[0] /= np.sqrt(2.0)
    return C


def high_frequencies(n: int, cutoff: float) -> FloatArray:
    """Indices ``l`` of the high-frequency set ``H = {l : l >= ceil(cutoff n)}`` (never l = 0)."""
    return np.arange(max(1, int(np.ceil(cutoff * n))), n)


def ramped_frequencies(n: int, cutoff: float) -> FloatArray:
    """The authors' high set ``H = {l : l / (N - 1) > cutoff}``."""
    ell = np.arange(n)
    return ell[ell / max(n - 1, 1) > cutoff]


def spectral_weights(n: int, cutoff: float, power: float, ramp: bool = False) -> FloatArray:
    """``gamma_l`` for ``l = 0..N-1`` (0 off ``H``).

    ``gamma_l = (l / (N - 1))^power`` on ``l >= ceil(cutoff N)`` (the paper's text), or with
    ``ramp`` the authors' ``gamma_l = ((l/(N-1) - c) / (1 - c))^power`` on ``l/(N-1) > c``.
    """
    H = ramped_frequencies(n, cutoff) if ramp else high_frequencies(n, cutoff)
    gamma = np.zeros(n)
    x = H / max(n - 1, 1)
    gamma[H] = ((x - cutoff) / (1 - cutoff)) ** power if ramp else x**power
    return gamma


def dct_penalty(n: int, cutoff: float, power: float, ramp: bool = False) -> FloatArray:
    """``P = C^T diag(gamma) C``, so ``b^T P b = sum_{l in H} gamma_l bhat_l^2`` (dense N x N)."""
    C = dct_matrix(n)
    gamma = spectral_weights(n, cutoff, power, ramp)
    H = np.flatnonzero(gamma)
    return C[H].T @ (gamma[H, None] * C[H])


def neumann_laplacian(n: int) -> sparse.csr_matrix:
    """``Lap = D^T D`` with ``D`` the (N-1) x N forward difference (tridiagonal)."""
    D = sparse.diags([-np.ones(n - 1), np.ones(n - 1)], [0, 1], shape=(max(n - 1, 0), n))
    return (D.T @ D).tocsr()


def squared_wavenumbers(n: int) -> FloatArray:
    """``kappa_l = (2N/pi)^2 sin^2(pi l / 2N)``: the eigenvalues of ``(N/pi)^2 Lap`` (-> ``l^2``)."""
    return (2 * n / np.pi) ** 2 * np.sin(np.pi * np.arange(n) / (2 * n)) ** 2


class SpectralForm(NamedTuple):
    """``P = banded + rows^T diag(gains) rows`` (see the module docstring).

    Attributes:
        kind: ``"dense"``, ``"lifted"`` (exact) or ``"banded"`` (the alternative weighting).
        banded: N x N sparse.
        rows: m x N dense rows (DCT-II rows ``C_l``), lifted as variables by the optimizer.
        gains: m gains.
    """

    kind: str
    banded: sparse.csr_matrix
    rows: FloatArray
    gains: FloatArray

    def matrix(self) -> FloatArray:
        """The dense N x N matrix the form stands for."""
        return self.banded.toarray() + self.rows.T @ (self.gains[:, None] * self.rows)

    def value(self, b: FloatArray) -> float:
        """``1/2 b^T P b`` evaluated through the form."""
        z = self.rows @ b
        return 0.5 * float(b @ (self.banded @ b) + z @ (self.gains * z))

    def gradient(self, b: FloatArray) -> FloatArray:
        """``P b`` evaluated through the form."""
        return self.banded @ b + self.rows.T @ (self.gains * (self.rows @ b))


def _split(n: int, high: FloatArray, gamma: FloatArray, banded: sparse.spmatrix, poly: FloatArray,
           kind: str) -> SpectralForm:
    """``C^T diag(gamma 1_H) C`` with ``gamma = poly`` on ``H``, ``banded = C^T diag(poly) C``:
    lift the smaller of ``H`` (rows ``C_H``, gains ``gamma_H``, no band) or its complement
    (the band, rows ``C_L``, gains ``-poly_L``)."""
    C = dct_matrix(n)
    low = np.setdiff1d(np.arange(n), high)
    if high.size <= low.size:
        return SpectralForm(kind, sparse.csr_matrix((n, n)), C[high], gamma[high])
    return SpectralForm(kind, sparse.csr_matrix(banded), C[low], -poly[low])


def exact_form(n: int, cutoff: float, power: float, ramp: bool = False) -> SpectralForm:
    """``P`` exactly: ``lifted`` when ``gamma`` is constant over ``H``, else ``dense``."""
    gamma = spectral_weights(n, cutoff, power, ramp)
    high = np.flatnonzero(gamma)
    if high.size == 0:
        return SpectralForm("lifted", sparse.csr_matrix((n, n)), np.zeros((0, n)), np.zeros(0))
    g0 = gamma[high[0]]
    if np.all(gamma[high] == g0):
        return _split(n, high, gamma, g0 * sparse.identity(n), np.full(n, g0), "lifted")
    return dense_form(n, cutoff, power, ramp)


def dense_form(n: int, cutoff: float, power: float, ramp: bool = False) -> SpectralForm:
    """``P`` as one dense matrix (the formula as written)."""
    return SpectralForm("dense", sparse.csr_matrix(dct_penalty(n, cutoff, power, ramp)), np.zeros((0, n)), np.zeros(0))


class _Banded(NamedTuple):
    """The banded weighting ``gamma_l = ((kappa_l - shift) / scale)^m`` on ``high``."""

    shift: float
    scale: float
    m: int
    high: FloatArray

    def poly(self, kappa: FloatArray) -> FloatArray:
        return ((kappa - self.shift) / self.scale) ** self.m


def _banded(n: int, cutoff: float, power: float, ramp: bool, reference: int) -> _Banded:
    if power % 2 != 0:
        raise InvalidInputError(f"dct_power: the banded form needs an even power (0, 2, 4, ...), got {power}")
    l_r, ell = reference - 1.0, np.arange(n)
    if ramp:
        l_c = cutoff * l_r
        shift = (2 * n / np.pi) ** 2 * np.sin(np.pi * min(l_c, n) / (2 * n)) ** 2  # kappa(l_c) at this N
        return _Banded(shift, l_r**2 - l_c**2, int(power) // 2, ell > l_c)
    return _Banded(0.0, l_r**2, int(power) // 2, ell >= max(1, int(np.ceil(cutoff * reference))))


def banded_weights(n: int, cutoff: float, power: float, ramp: bool, reference: int) -> FloatArray:
    """The resolution-independent alternative to :func:`spectral_weights`, ``gamma_l = p(kappa_l)``.

    Frequencies are wavenumbers ``l`` (cosine ``l`` has ``l/2`` periods over the horizon, ``l / (2T)``
    Hz for a horizon of ``T`` seconds: on the authors' lift, 41 waypoints 0.25 s apart, the cutoff
    ``l_c = 4`` is about 0.2 Hz at every N), the cutoff and the scale are those of the
    ``reference``-waypoint horizon: ``l_r = reference - 1`` and ``m = power / 2`` (an even
    ``power``). With ``ramp`` (the authors' set)::

        H = {l : l > l_c},  l_c = c l_r,    gamma_l = ((kappa_l - kappa(l_c)) / (l_r^2 - l_c^2))^m

    else (the paper's text) ``H = {l : l >= ceil(c reference)}``, ``gamma_l = (kappa_l / l_r^2)^m``.
    ``kappa(l_c)`` is the squared wavenumber of ``l_c`` at this N, so ``gamma >= 0`` on ``H``.
    As N grows ``kappa_l -> l^2``: ``gamma`` tends to the fixed function ``((l^2 - l_c^2) /
    (l_r^2 - l_c^2))^m`` of the wavenumber, and ``|L|`` stays ``floor(l_c) + 1``.

    Against the authors' ramp ``((l - l_c) / (l_r - l_c))^2`` (``m = 1``): both are 0 at the
    cutoff and about 1 at ``l_r``; this one rises linearly from the cutoff where the ramp rises
    quadratically, and grows like ``l^2`` above ``l_r`` where the authors' weights stop at the
    Nyquist frequency of each horizon (their cutoff moves with N: ``l_c = c (N - 1)``).
    """
    b = _banded(n, cutoff, power, ramp, reference)
    return np.where(b.high, b.poly(squared_wavenumbers(n)), 0.0)


def banded_form(n: int, cutoff: float, power: float, ramp: bool, reference: int) -> SpectralForm:
    """:func:`banded_weights` as a band of ``m = power/2`` off-diagonals plus the low rows."""
    b = _banded(n, cutoff, power, ramp, reference)
    step = ((n / np.pi) ** 2 * neumann_laplacian(n) - b.shift * sparse.identity(n)) / b.scale
    band = sparse.identity(n)
    for _ in range(b.m):
        band = band @ step
    poly = b.poly(squared_wavenumbers(n))
    return _split(n, np.flatnonzero(b.high), np.where(b.high, poly, 0.0), band, poly, "banded")


def spectral_form(n: int, cutoff: float, power: float, ramp: bool, form: str = "auto",
                  reference: int = 41) -> SpectralForm:
    """The form of J5's matrix the optimizer solves with (the ``base_spectral`` term's ``form``).

    ``dense`` and ``banded`` as named; ``exact``: :func:`exact_form` (lifted when it can be,
    else dense); ``auto``: ``exact`` when that is lifted or ``n <= DENSE_MAX_WAYPOINTS``, else
    ``banded`` (``exact`` when the power is odd).
    """
    if form not in DCT_FORMS:
        raise InvalidInputError(f"dct_form: expected one of {', '.join(DCT_FORMS)}, got {form!r}")
    if form == "dense":
        return dense_form(n, cutoff, power, ramp)
    if form == "banded":
        return banded_form(n, cutoff, power, ramp, reference)
    exact = exact_form(n, cutoff, power, ramp)
    if form == "exact" or exact.kind == "lifted" or n <= DENSE_MAX_WAYPOINTS or power % 2 != 0:
        return exact
    return banded_form(n, cutoff, power, ramp, reference)
