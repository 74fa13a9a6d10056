"""Per-waypoint kernels called over a horizon without CasADi's call overhead.

The structure-exploiting solver evaluates the stage kernels of :mod:`forte.planning.nlp.kernels`
(cost, gradient, 30 x 30 Hessian, pose residual, Jacobian and Hessian) at every waypoint, several
times per re-plan. Through CasADi a mapped call costs its computation plus the conversion of the
result to NumPy (1.3 ms for the lift's 41 stage Hessians, more than the 0.9 ms of arithmetic), so
this module calls the compiled functions directly: a 20-line C loop (compiled once, cached
next to the kernels with the same size and sha256 record) walks the horizon and calls the kernel
with pointers into NumPy arrays; one ``ctypes`` call per kernel and horizon.

The generated kernels are pure functions of dense inputs (no work arrays, no memory objects;
checked when loading). Without a compiled library (no C compiler, a read-only cache) the same
interface runs CasADi's mapped functions.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from forte.planning.nlp.kernels import Kernels, _digest, _record_path, verify_library
from forte.validation import FloatArray

_SHIM = r"""
typedef long long casadi_int;
typedef int (*kernel_t)(const double**, double**, casadi_int*, double*, int);
/* call f once per waypoint k, input i at in[i] + k * in_stride[i] (stride 0: shared) */
int forte_map(kernel_t f, int n, int n_in, const double** in, const long long* in_stride,
              int n_out, double** out, const long long* out_stride, int sz_arg, int sz_res) {
  const double* arg[64]; double* res[64];
  if (sz_arg > 64 || sz_res > 64) return -1;
  for (int i = 0; i < 64; ++i) { arg[i] = 0; res[i] = 0; }
  for (int k = 0; k < n; ++k) {
    for (int i = 0; i < n_in; ++i) arg[i] = in[i] + k * in_stride[i];
    for (int o = 0; o < n_out; ++o) res[o] = out[o] + k * out_stride[o];
    if (f(arg, res, 0, 0, 0)) return k + 1;
  }
  return 0;
}
"""

_LONGS = ctypes.c_longlong


class StageMap:
    """One kernel over ``n`` waypoints: ``outputs[o][k] = kernel(inputs[i][k] ...)``.

    Inputs are ``(n, size)`` C-ordered arrays (or ``(size,)`` for a value shared by every
    waypoint); outputs ``(n, size)`` in CasADi's column-major order of each output.
    """

    def __init__(self, fn: ca.Function, lib: ctypes.CDLL | None, shim: Any, clock: list[float] | None = None) -> None:
        self.fn = fn
        self.clock = clock if clock is not None else [0.0]  # seconds spent in this kernel's calls, summed
        self.sizes_in = [fn.sparsity_in(i).numel() for i in range(fn.n_in())]
        self.sizes_out = [fn.sparsity_out(i).numel() for i in range(fn.n_out())]
        self._mapped: dict[int, ca.Function] = {}
        self._native = None
        if lib is not None and shim is not None and _plain(fn):
            self._native = ctypes.cast(getattr(lib, fn.name()), ctypes.c_void_p)
            self._shim = shim
            self._sz = (int(fn.sz_arg()), int(fn.sz_res()))
            self._ostrides = (_LONGS * len(self.sizes_out))(*self.sizes_out)
        self._last: tuple | None = None  # the last call's inputs after the first, and their pointers

    @property
    def native(self) -> bool:
        return self._native is not None

    def __call__(self, n: int, *inputs: FloatArray) -> list[FloatArray]:
        start = time.perf_counter()
        try:
            return self._call(n, inputs)
        finally:
            self.clock[0] += time.perf_counter() - start

    def _call(self, n: int, inputs: tuple[FloatArray, ...]) -> list[FloatArray]:
        outs = [np.empty((n, size)) for size in self.sizes_out]
        if self._native is None:
            return self._virtual(n, [np.ascontiguousarray(a, dtype=float) for a in inputs], outs)
        last = self._last
        if last is not None and len(last[0]) == len(inputs) - 1 and all(
                a is b for a, b in zip(last[0], inputs[1:], strict=True)):
            # the same task data as the last call (a solve's iterations): only the first input is new
            arrays, ptrs, strides = last[1], last[2], last[3]
            arrays[0] = np.ascontiguousarray(inputs[0], dtype=float)
            ptrs[0], strides[0] = arrays[0].ctypes.data, 0 if arrays[0].ndim == 1 else arrays[0].shape[1]
        else:
            arrays = [np.ascontiguousarray(a, dtype=float) for a in inputs]
            ptrs = (ctypes.c_void_p * len(arrays))(*[a.ctypes.data for a in arrays])
            strides = (_LONGS * len(arrays))(*[0 if a.ndim == 1 else a.shape[1] for a in arrays])
            if all(a is b for a, b in zip(arrays[1:], inputs[1:], strict=True)):  # no copies: their memory
                self._last = (inputs[1:], arrays, ptrs, strides)  # holding the inputs keeps their identity
        optrs = (ctypes.c_void_p * len(outs))(*[o.ctypes.data for o in outs])
        code = self._shim(self._native, n, len(arrays), ptrs, strides, len(outs), optrs, self._ostrides, *self._sz)
        if code != 0:
            raise FloatingPointError(f"kernel {self.fn.name()} failed at waypoint {code - 1}")
        return outs

    def _virtual(self, n: int, arrays: list[FloatArray], outs: list[FloatArray]) -> list[FloatArray]:
        if n not in self._mapped:
            self._mapped[n] = self.fn.map(n)
        args = [np.tile(a[:, None], (1, n)) if a.ndim == 1 else a.T for a in arrays]
        res = self._mapped[n](*args)
        res = res if isinstance(res, (list, tuple)) else [res]
        for o, r in zip(outs, res, strict=True):
            o[:] = np.asarray(r.full() if hasattr(r, "full") else r).reshape(-1, n, order="F").T \
                if o.shape[1] > 1 else np.asarray(r.full()).reshape(1, n).T
        return outs


def _plain(fn: ca.Function) -> bool:
    """Dense inputs and outputs, no work arrays: the shim may call it directly."""
    dense = all(fn.sparsity_in(i).is_dense() for i in range(fn.n_in())) and \
        all(fn.sparsity_out(i).is_dense() for i in range(fn.n_out()))
    return dense and fn.sz_iw() == 0 and fn.sz_w() == 0 and fn.sz_arg() <= 64 and fn.sz_res() <= 64


class StageKernels:
    """The optimizer's kernels as :class:`StageMap` s (``native`` when compiled)."""

    def __init__(self, kernels: Kernels) -> None:
        lib = shim = None
        if kernels.library is not None:
            shim = load_shim(kernels.library.parent)
            lib = ctypes.CDLL(str(kernels.library)) if shim is not None else None
        self.clock = [0.0]  # seconds in every kernel call, summed (the solver's time split)
        self.cost, self.grad, self.hess = (StageMap(f, lib, shim, self.clock)
                                           for f in (kernels.cost, kernels.grad, kernels.hess))
        self.pose, self.pose_jac, self.pose_hess = (
            StageMap(f, lib, shim, self.clock) for f in (kernels.pose, kernels.pose_jac, kernels.pose_hess))

    @property
    def native(self) -> bool:
        return self.hess.native


_LIBRARIES: dict[str, ctypes.CDLL | None] = {}


def load_c_library(folder: Path, stem: str, source: str) -> ctypes.CDLL | None:
    """``source`` compiled once into ``folder/STEM_HASH.so`` (with the size and sha256 record the
    kernels have) and loaded; None without a compiler or a writable cache."""
    key = hashlib.sha256(source.encode()).hexdigest()[:16]
    lib = folder / f"{stem}_{key}.so"
    if str(lib) not in _LIBRARIES:
        loaded = None
        try:
            if verify_library(lib) is not None:
                _compile_c(lib, source)
            if verify_library(lib) is None:
                loaded = ctypes.CDLL(str(lib))
        except (OSError, subprocess.CalledProcessError):
            loaded = None
        _LIBRARIES[str(lib)] = loaded
    return _LIBRARIES[str(lib)]


def load_shim(folder: Path) -> Any:
    """The compiled horizon loop (compiled once into ``folder``), or None without a compiler."""
    lib = load_c_library(folder, "stage_map", _SHIM)
    if lib is None:
        return None
    fn = lib.forte_map
    fn.restype = ctypes.c_int
    fn.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p,
                   ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_int]
    return fn


def _compile_c(lib: Path, source: str) -> None:
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        raise OSError("no C compiler")
    lib.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=lib.parent) as tmp:
        src, out = Path(tmp) / f"{lib.stem}.c", Path(tmp) / f"{lib.stem}.so"
        src.write_text(source, encoding="utf-8")
        subprocess.run([compiler, "-O2", "-shared", "-fPIC", str(src), "-o", str(out), "-lm"], check=True,
                       capture_output=True)
        rec = Path(tmp) / "record.json"
        record = {"size": out.stat().st_size, "sha256": _digest(out)}
        rec.write_text(json.dumps(record) + "\n", encoding="utf-8")
        os.replace(rec, _record_path(lib))  # the record first, as forte.planning.nlp.kernels does
        os.replace(out, lib)
