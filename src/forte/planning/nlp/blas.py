"""One BLAS thread for latency-bound solves.

A re-plan calls three OpenBLAS builds: CasADi's (IPOPT's linear solver MUMPS), NumPy's (the
metrics of the new plan) and SciPy's (the stagewise solver's factorizations). Its matrices are
small (KKT systems of a few thousand rows, 41 x 6 x 7 Jacobians), so worker threads gain
nothing; worse, OpenBLAS workers busy-wait after each call: measured on the lift's re-plans,
NumPy's worker burned as much CPU as the solve itself, a core taken from the solve on a shared
2-core machine (and SciPy's threaded Cholesky of a 148 x 148 matrix took 85 ms instead of
0.1 ms while another process ran). The warm re-plans of :mod:`forte.planning.online.replan` and the
stagewise solves therefore run with one thread in each. The counts are process-wide, so they
are set for the solve and restored after it; a build that is not found (another BLAS) is left
alone.
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache
from pathlib import Path
from typing import Any, NamedTuple

import casadi as ca
import numpy as np


class BlasThreads(NamedTuple):
    """The thread-count getter and setter of one OpenBLAS build."""

    get: Any
    set: Any


#: (folder, file pattern, getter, setter) of the builds a re-plan calls.
BUILDS = (
    (Path(ca.__file__).parent, "libcasadi-tp-openblas*", "openblas_get_num_threads", "openblas_set_num_threads"),
    (Path(np.__file__).parent.parent / "numpy.libs", "libscipy_openblas*",
     "scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"),
    # SciPy's own build (its LAPACK: the interior-point solver's Cholesky factorizations)
    (Path(np.__file__).parent.parent / "scipy.libs", "libscipy_openblas-*",
     "scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
)


@cache
def openblas_builds() -> tuple[BlasThreads, ...]:
    """The OpenBLAS builds of :data:`BUILDS` that are present (loaded through ctypes)."""
    found = []
    for folder, pattern, getter, setter in BUILDS:
        for path in sorted(folder.glob(pattern)):
            try:
                lib = ctypes.CDLL(str(path))
                get, put = getattr(lib, getter), getattr(lib, setter)
            except (OSError, AttributeError):
                continue
            get.restype, put.argtypes = ctypes.c_int, [ctypes.c_int]
            found.append(BlasThreads(get, put))
            break
    return tuple(found)


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Run the block with one thread in every OpenBLAS build found, then restore the counts."""
    builds = openblas_builds()
    before = [b.get() for b in builds]
    for b in builds:
        b.set(1)
    try:
        yield
    finally:
        for b, count in zip(builds, before, strict=True):
            b.set(count)
