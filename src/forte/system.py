"""What this process may use of the machine: its CPUs, and the environment that keeps the
numeric libraries to one thread each.

The lowest level of forte (it imports nothing of forte): the kernel compiler, the figure
processes, the command line and the sweep workers all read it.
"""

from __future__ import annotations

import os

#: One thread per BLAS / OpenMP library (OpenBLAS: NumPy's, SciPy's and CasADi's, IPOPT's MUMPS;
#: MKL where NumPy uses it; OpenMP). Set before the library loads; it reads the variable once.
SINGLE_THREAD_ENV: dict[str, str] = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def cpu_count() -> int:
    """The CPUs this process may run on: its affinity mask where the OS has one (Linux; a
    container or ``taskset`` may allow fewer than the machine has), else all the machine's."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1
