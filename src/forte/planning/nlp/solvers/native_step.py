"""The stagewise solver's Newton step around the factorization, in compiled code.

:meth:`~forte.planning.nlp.solvers.interior_point.InteriorPoint.step` in NumPy makes some sixty small
array calls per iteration (window reductions, scatters, triangular solves, Hessian products),
each a few microseconds of Python for a few hundred flops: at N = 41 that is 0.7 ms per
iteration around a factorization of 0.05 ms. Here the same arithmetic runs in two C calls, the
dense Cholesky with IPOPT's inertia correction staying with LAPACK
(:class:`~forte.planning.nlp.solvers.reduced_system.ReducedSystem`) in between:

1. ``prepare``: the window Hessians (stage, ``D``'s near-diagonal part, pose rows' curvature,
   kinematic rows' barrier); ``J^T = [Y Z] [R; 0]`` per posed block (Householder); ``p_Y = -R^-T c``
   and ``y_Y = Y p_Y``; the right-hand side ``-Z^T (g + H y_Y)``; the lower triangle of the
   reduced matrix ``M = Z^T (W + R^T G R) Z + sum_k Zw_k^T H_k Zw_k + Z^T diag(b) Z`` (the rest of
   ``Q``, the windows reduced slot pair by slot pair, the bounds' barrier per block): the
   Cholesky reads no more;
2. ``finish``: ``dy = y_Y + Z p_Z`` and the multipliers ``lam = -R^-1 Y^T (g + H dy + delta dy)``.

``H v`` is the windows' scatter of ``H_k v_k`` plus ``scale (W v + R^T diag(g) R v)`` (``Q``'s part
outside the windows: a CSR matrix and the dense lifted rows) plus ``diag(b) v``, as NumPy's. The
library is compiled once next to the kernels, with their size and sha256 record; without a
compiler the NumPy step runs (same numbers; the tests compare the two).
"""

from __future__ import annotations

import ctypes
import time
from pathlib import Path
from typing import Any

import numpy as np

from forte.planning.nlp.solvers.native import load_c_library
from forte.validation import FloatArray

_SOURCE = r"""
#include <math.h>
#include <string.h>
typedef long long i64;

typedef struct {
  int n, nq, r, blocks, P, L, m, d;
  double *Hw, *Z, *Y, *R;  /* computed by prepare */
  const double *g, *bdiag, *Ry, *gr, *Wx, *Hs, *Dw, *PH, *J, *kc, *ks, *W;
  const i64 *wb, *wy, *posed, *Wp, *Wi, *posed_x, *kflat, *wdofs;
  double scale;
} layout;

/* Hw = Hs + scale Dw, the pose rows' curvature on the posed waypoints' own slot, the kinematic
   rows' barrier c c^T sigma on their window entries */
static void window_hessians(const layout* s) {
  int nq = s->nq, w = 3 * nq;
  i64 size = (i64)s->n * w * w;
  for (i64 i = 0; i < size; ++i) s->Hw[i] = s->Hs[i] + s->scale * s->Dw[i];
  for (int p = 0; p < s->P; ++p) {
    double* H = s->Hw + s->posed_x[p] * w * w;
    const double* P = s->PH + (i64)p * nq * nq;
    for (int i = 0; i < nq; ++i)
      for (int j = 0; j < nq; ++j) H[(2 * nq + i) * w + 2 * nq + j] += P[i * nq + j];
  }
  for (int i = 0; i < s->m; ++i)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        s->Hw[s->kflat[i * 9 + a * 3 + b]] += s->kc[i * 3 + a] * s->kc[i * 3 + b] * s->ks[i];
}

/* J_p^T = [Y_p Z_p] [R_p; 0] by Householder reflections (nq x 6 per posed block); unposed
   blocks: Z = the identity (r = nq), posed ones padded with zero columns when r = nq */
static int bases(const layout* s) {
  int nq = s->nq, r = s->r;
  double A[nq * 6], Q[nq * nq], v[nq];
  memset(s->Z, 0, sizeof(double) * s->blocks * nq * r);
  if (r == nq)
    for (int b = 0; b < s->blocks; ++b)
      for (int i = 0; i < nq; ++i) s->Z[((i64)b * nq + i) * r + i] = 1.0;
  for (int p = 0; p < s->P; ++p) {
    const double* J = s->J + (i64)p * 6 * nq;
    for (int i = 0; i < nq; ++i)
      for (int j = 0; j < 6; ++j) A[i * 6 + j] = J[j * nq + i];
    for (int i = 0; i < nq * nq; ++i) Q[i] = 0.0;
    for (int i = 0; i < nq; ++i) Q[i * nq + i] = 1.0;
    for (int j = 0; j < 6; ++j) {
      double norm = 0.0;
      for (int i = j; i < nq; ++i) norm += A[i * 6 + j] * A[i * 6 + j];
      norm = sqrt(norm);
      if (norm == 0.0) return 1;
      double alpha = A[j * 6 + j] > 0 ? -norm : norm, vv = 0.0;
      for (int i = j; i < nq; ++i) v[i] = A[i * 6 + j];
      v[j] -= alpha;
      for (int i = j; i < nq; ++i) vv += v[i] * v[i];
      if (vv == 0.0) continue;
      for (int k = j; k < 6; ++k) {  /* A <- H A */
        double t = 0.0;
        for (int i = j; i < nq; ++i) t += v[i] * A[i * 6 + k];
        t *= 2.0 / vv;
        for (int i = j; i < nq; ++i) A[i * 6 + k] -= t * v[i];
      }
      for (int i = 0; i < nq; ++i) {  /* Q <- Q H */
        double t = 0.0;
        for (int k = j; k < nq; ++k) t += Q[i * nq + k] * v[k];
        t *= 2.0 / vv;
        for (int k = j; k < nq; ++k) Q[i * nq + k] -= t * v[k];
      }
    }
    double* R = s->R + p * 36;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) R[i * 6 + j] = j >= i ? A[i * 6 + j] : 0.0;
    double* Y = s->Y + (i64)p * nq * 6;
    double* Z = s->Z + s->posed[p] * nq * r;
    for (int i = 0; i < nq; ++i) {
      for (int j = 0; j < 6; ++j) Y[i * 6 + j] = Q[i * nq + j];
      for (int j = 0; j < r; ++j) Z[i * r + j] = j < nq - 6 ? Q[i * nq + 6 + j] : 0.0;
    }
  }
  return 0;
}

/* M = Z^T (W + R^T diag(scale g) R) Z: W dense on d dofs of every block (blocks d x blocks d) */
static void reduced_quadratic(const layout* s, double* M) {
  int nq = s->nq, r = s->r, d = s->d, nb = s->blocks, nr = nb * r, ny = nb * nq;
  memset(M, 0, sizeof(double) * nr * nr);
  if (d) {
    double T[d * r];
    for (int bi = 0; bi < nb; ++bi)
      for (int bj = 0; bj <= bi; ++bj) {
        const double* Zj = s->Z + (i64)bj * nq * r;
        const double* Zi = s->Z + (i64)bi * nq * r;
        for (int m = 0; m < d; ++m)  /* T = W_ij Zs_j */
          for (int c = 0; c < r; ++c) {
            double acc = 0.0;
            for (int k = 0; k < d; ++k) acc += s->W[((i64)bi * d + m) * nb * d + bj * d + k] * Zj[s->wdofs[k] * r + c];
            T[m * r + c] = acc;
          }
        for (int a = 0; a < r; ++a)
          for (int c = 0; c < r; ++c) {
            double acc = 0.0;
            for (int m = 0; m < d; ++m) acc += Zi[s->wdofs[m] * r + a] * T[m * r + c];
            M[((i64)bi * r + a) * nr + bj * r + c] += s->scale * acc;
          }
      }
  }
  if (s->L) {
    double rz[nr];
    for (int l = 0; l < s->L; ++l) {
      const double* row = s->Ry + (i64)l * ny;
      for (int b = 0; b < nb; ++b)
        for (int a = 0; a < r; ++a) {
          double acc = 0.0;
          for (int m = 0; m < nq; ++m) acc += row[b * nq + m] * s->Z[((i64)b * nq + m) * r + a];
          rz[b * r + a] = acc;
        }
      double gl = s->scale * s->gr[l];
      for (int i = 0; i < nr; ++i) {
        if (rz[i] == 0.0) continue;
        double t = gl * rz[i];
        for (int j = 0; j <= i; ++j) M[(i64)i * nr + j] += t * rz[j];
      }
    }
  }
}

/* out = H v: windows, Q's rest, bounds' barrier */
static void hv(const layout* s, const double* v, double* out) {
  int w = 3 * s->nq, ny = s->blocks * s->nq;
  double vw[w];
  memset(out, 0, sizeof(double) * ny);
  for (int k = 0; k < s->n; ++k) {
    const i64* idx = s->wy + (i64)k * w;
    const double* H = s->Hw + (i64)k * w * w;
    for (int i = 0; i < w; ++i) vw[i] = idx[i] < ny ? v[idx[i]] : 0.0;
    for (int i = 0; i < w; ++i) {
      if (idx[i] >= ny) continue;
      double acc = 0.0;
      for (int j = 0; j < w; ++j) acc += H[i * w + j] * vw[j];
      out[idx[i]] += acc;
    }
  }
  for (int i = 0; i < ny; ++i) {
    double acc = 0.0;
    for (i64 p = s->Wp[i]; p < s->Wp[i + 1]; ++p) acc += s->Wx[p] * v[s->Wi[p]];
    out[i] += s->scale * acc + s->bdiag[i] * v[i];
  }
  for (int l = 0; l < s->L; ++l) {
    const double* row = s->Ry + (i64)l * ny;
    double t = 0.0;
    for (int i = 0; i < ny; ++i) t += row[i] * v[i];
    t *= s->scale * s->gr[l];
    for (int i = 0; i < ny; ++i) out[i] += row[i] * t;
  }
}

int forte_step_prepare(const layout* s, const double* c, double* M, double* rhs, double* ypy, double* work) {
  int nq = s->nq, r = s->r, w = 3 * nq, ny = s->blocks * nq, nr = s->blocks * r;
  window_hessians(s);
  if (bases(s)) return 1;
  reduced_quadratic(s, M);
  memset(ypy, 0, sizeof(double) * ny);
  for (int p = 0; p < s->P; ++p) {  /* p_Y = -R^-T c (R upper triangular), y_Y = Y p_Y */
    const double* R = s->R + p * 36;
    const double* Y = s->Y + (i64)p * nq * 6;
    double u[6];
    for (int i = 0; i < 6; ++i) {
      double acc = -c[p * 6 + i];
      for (int j = 0; j < i; ++j) acc -= R[j * 6 + i] * u[j];
      if (R[i * 6 + i] == 0.0) return 1;
      u[i] = acc / R[i * 6 + i];
    }
    double* out = ypy + s->posed[p] * nq;
    for (int a = 0; a < nq; ++a) {
      double acc = 0.0;
      for (int j = 0; j < 6; ++j) acc += Y[a * 6 + j] * u[j];
      out[a] = acc;
    }
  }
  hv(s, ypy, work);
  for (int b = 0; b < s->blocks; ++b) {
    const double* Z = s->Z + (i64)b * nq * r;
    for (int a = 0; a < r; ++a) {
      double acc = 0.0;
      for (int m = 0; m < nq; ++m) acc += Z[m * r + a] * (work[b * nq + m] + s->g[b * nq + m]);
      rhs[b * r + a] = -acc;
    }
  }
  double T[nq * r];
  for (int k = 0; k < s->n; ++k) {
    const double* H = s->Hw + (i64)k * w * w;
    for (int sa = 0; sa < 3; ++sa) {
      i64 ba = s->wb[k * 3 + sa];
      if (ba >= s->blocks) continue;
      const double* Za = s->Z + ba * nq * r;
      for (int sb = 0; sb <= sa; ++sb) {  /* the lower triangle: later slots have later blocks */
        i64 bb = s->wb[k * 3 + sb];
        if (bb >= s->blocks) continue;
        const double* Zb = s->Z + bb * nq * r;
        for (int i = 0; i < nq; ++i)
          for (int j = 0; j < r; ++j) {
            double acc = 0.0;
            for (int m = 0; m < nq; ++m) acc += H[(sa * nq + i) * w + sb * nq + m] * Zb[m * r + j];
            T[i * r + j] = acc;
          }
        int mirrored = sb < sa && ba == bb;  /* two slots of one block: the (sb, sa) pair lands here too */
        for (int a = 0; a < r; ++a)
          for (int j = 0; j < r; ++j) {
            double acc = 0.0;
            for (int i = 0; i < nq; ++i) acc += Za[i * r + a] * T[i * r + j];
            M[(ba * r + a) * nr + bb * r + j] += acc;
            if (mirrored) M[(bb * r + j) * nr + ba * r + a] += acc;
          }
      }
    }
  }
  for (int b = 0; b < s->blocks; ++b) {
    const double* Z = s->Z + (i64)b * nq * r;
    const double* d = s->bdiag + b * nq;
    for (int a = 0; a < r; ++a)
      for (int j = 0; j < r; ++j) {
        double acc = 0.0;
        for (int m = 0; m < nq; ++m) acc += Z[m * r + a] * d[m] * Z[m * r + j];
        M[(b * r + a) * nr + b * r + j] += acc;
      }
  }
  return 0;
}

int forte_step_finish(const layout* s, const double* pZ, double delta, const double* ypy, double* dy,
                      double* lam, double* work) {
  int nq = s->nq, r = s->r, ny = s->blocks * nq;
  for (int b = 0; b < s->blocks; ++b) {
    const double* Z = s->Z + (i64)b * nq * r;
    for (int m = 0; m < nq; ++m) {
      double acc = ypy[b * nq + m];
      for (int a = 0; a < r; ++a) acc += Z[m * r + a] * pZ[b * r + a];
      dy[b * nq + m] = acc;
    }
  }
  hv(s, dy, work);
  for (int i = 0; i < ny; ++i) work[i] += s->g[i] + delta * dy[i];
  for (int p = 0; p < s->P; ++p) {  /* lam = -R^-1 Y^T (g + H dy + delta dy) */
    const double* R = s->R + p * 36;
    const double* Y = s->Y + (i64)p * nq * 6;
    const double* res = work + s->posed[p] * nq;
    double u[6], x[6];
    for (int j = 0; j < 6; ++j) {
      double acc = 0.0;
      for (int m = 0; m < nq; ++m) acc += Y[m * 6 + j] * res[m];
      u[j] = acc;
    }
    for (int i = 5; i >= 0; --i) {
      double acc = u[i];
      for (int j = i + 1; j < 6; ++j) acc -= R[i * 6 + j] * x[j];
      if (R[i * 6 + i] == 0.0) return 1;
      x[i] = acc / R[i * 6 + i];
    }
    for (int i = 0; i < 6; ++i) lam[p * 6 + i] = -x[i];
  }
  return 0;
}
"""

_P = ctypes.c_void_p
_INTS = ("n", "nq", "r", "blocks", "P", "L", "m", "d")
_POINTERS = ("Hw", "Z", "Y", "R", "g", "bdiag", "Ry", "gr", "Wx", "Hs", "Dw", "PH", "J", "kc", "ks", "W",
             "wb", "wy", "posed", "Wp", "Wi", "posed_x", "kflat", "wdofs")


class _Layout(ctypes.Structure):
    _fields_ = [(name, ctypes.c_int) for name in _INTS] + [(name, _P) for name in _POINTERS] + \
        [("scale", ctypes.c_double)]


def _ptr(a: np.ndarray) -> int:
    return a.ctypes.data


class NativeStep:
    """The compiled step of one :class:`~forte.planning.nlp.solvers.stage_problem.StageProblem` (dense
    reduced form). The arrays of a :meth:`prepare` are kept until the next one; :attr:`Y` and
    :attr:`R` (``J^T = Y R`` per posed block) are overwritten by it."""

    def __init__(self, lib: ctypes.CDLL, pb: Any, r: int, wb: FloatArray, wy: FloatArray) -> None:
        self._prepare, self._finish = lib.forte_step_prepare, lib.forte_step_finish
        self._prepare.argtypes = [_P] * 6
        self._finish.argtypes = [_P, _P, ctypes.c_double, _P, _P, _P, _P]
        for fn in (self._prepare, self._finish):
            fn.restype = ctypes.c_int
        self.pb, self.r = pb, r
        n, nq, blocks, P = pb.n, pb.nq, pb.blocks, pb.posed.size
        wide, wdofs = pb.Wy.tocsr(), pb.wide_dofs.astype(np.int64)
        self.Hw, self.Z = np.empty((n, 3 * nq, 3 * nq)), np.empty((blocks, nq, r))
        self.Y, self.R = np.empty((P, nq, 6)), np.empty((P, 6, 6))
        self._const = {"wb": np.ascontiguousarray(wb, dtype=np.int64), "wy": np.ascontiguousarray(wy, dtype=np.int64),
                       "posed": np.ascontiguousarray(pb.posed_block, dtype=np.int64),
                       "posed_x": np.ascontiguousarray(pb.posed, dtype=np.int64),
                       "Wp": wide.indptr.astype(np.int64), "Wi": wide.indices.astype(np.int64),
                       "Wx": np.ascontiguousarray(wide.data, dtype=float),
                       "W": np.ascontiguousarray(pb.W_dofs, dtype=float), "wdofs": wdofs,
                       "Ry": np.ascontiguousarray(pb.Ry.toarray(), dtype=float),
                       "gr": np.ascontiguousarray(pb.g, dtype=float), "Dw": np.ascontiguousarray(pb.Dw, dtype=float),
                       "Hw": self.Hw, "Z": self.Z, "Y": self.Y, "R": self.R}
        self.layout = _Layout(n=n, nq=nq, r=r, blocks=blocks, P=P, L=pb.g.size, d=wdofs.size)
        for name, arr in self._const.items():
            setattr(self.layout, name, _ptr(arr))
        self._work, self._ypy = np.empty(pb.ny), np.empty(pb.ny)
        self._keep: tuple = ()
        self.clock = [0.0]  # seconds in the compiled calls, summed (the benchmark's time split)

    @classmethod
    def load(cls, folder: Path | None, pb: Any, r: int, wb: FloatArray, wy: FloatArray) -> NativeStep | None:
        """The compiled step, or None (no compiler, no cache folder)."""
        lib = None if folder is None else load_c_library(folder, "newton_step", _SOURCE)
        return None if lib is None else cls(lib, pb, r, wb, wy)

    def prepare(self, stage_hessians: FloatArray, pose_hessians: FloatArray, J: FloatArray, c: FloatArray,
                g: FloatArray, bdiag: FloatArray, kin_sigma: FloatArray, kin_coef: FloatArray, kin_flat: FloatArray,
                scale: float) -> tuple[FloatArray, FloatArray]:
        """``(M, rhs)``: the reduced matrix (its lower triangle, before the padded columns' ones) and
        the right-hand side; :attr:`Z`, :attr:`Y`, :attr:`R` and the window Hessians :attr:`Hw` as
        computed on the way."""
        arrays = {"Hs": np.ascontiguousarray(stage_hessians, dtype=float),
                  "PH": np.ascontiguousarray(pose_hessians, dtype=float), "J": np.ascontiguousarray(J, dtype=float),
                  "g": np.ascontiguousarray(g, dtype=float), "bdiag": np.ascontiguousarray(bdiag, dtype=float),
                  "ks": np.ascontiguousarray(kin_sigma, dtype=float),
                  "kc": np.ascontiguousarray(kin_coef, dtype=float),
                  "kflat": np.ascontiguousarray(kin_flat, dtype=np.int64)}
        self._keep = tuple(arrays.values())
        for name, arr in arrays.items():
            setattr(self.layout, name, _ptr(arr))
        self.layout.scale, self.layout.m = float(scale), arrays["ks"].size
        c = np.ascontiguousarray(c, dtype=float)
        nr = self.pb.blocks * self.r
        M, rhs = np.empty((nr, nr)), np.empty(nr)
        begin = time.perf_counter()
        failed = self._prepare(ctypes.byref(self.layout), _ptr(c), _ptr(M), _ptr(rhs), _ptr(self._ypy),
                               _ptr(self._work))
        self.clock[0] += time.perf_counter() - begin
        if failed:
            raise np.linalg.LinAlgError("singular pose Jacobian")
        return M, rhs

    def finish(self, pZ: FloatArray, delta: float) -> tuple[FloatArray, FloatArray]:
        """``(dy, lam_new)`` from the reduced step ``pZ`` (after :meth:`prepare`)."""
        pZ = np.ascontiguousarray(pZ, dtype=float)
        dy, lam = np.empty(self.pb.ny), np.empty((self.pb.posed.size, 6))
        begin = time.perf_counter()
        failed = self._finish(ctypes.byref(self.layout), _ptr(pZ), ctypes.c_double(delta), _ptr(self._ypy),
                              _ptr(dy), _ptr(lam), _ptr(self._work))
        self.clock[0] += time.perf_counter() - begin
        if failed:
            raise np.linalg.LinAlgError("singular pose Jacobian")
        return dy, lam
