"""The processor the compiled kernels are built for.

The kernels (:mod:`forte.planning.nlp.kernels`, :mod:`forte.planning.nlp.collision_kernels`) are built
with ``-march=native`` where the compiler accepts it: fused multiply-adds and the processor's
vector instructions (``benchmarks/bench_replan.py`` with and without ``FORTE_PORTABLE_KERNELS=1``
measures what it gives; README, Performance).
Fused multiply-adds round once where a multiply and an add round twice, so results differ from a
portable build in the last bits (about 1e-16 relative per operation).

The instructions ``-march=native`` selects are part of the cache key (:func:`signature`: the
compiler's own expansion of the flag), so a cache shared between machines never hands one a
library built for another's instructions. ``FORTE_PORTABLE_KERNELS=1`` builds for the compiler's
default target instead (as does a compiler that does not accept the flag).
"""

from __future__ import annotations

import functools
import hashlib
import os
import subprocess

#: Environment variable that turns the processor-specific build off (any value but "" or "0").
PORTABLE_ENV = "FORTE_PORTABLE_KERNELS"


@functools.cache
def _native(compiler: str) -> str | None:
    """The compiler's expansion of ``-march=native`` (its ``cc1`` command line), or None."""
    try:
        proc = subprocess.run([compiler, "-march=native", "-x", "c", "-E", "-v", "-"], input="",
                              capture_output=True, text=True, timeout=30, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    lines = [line for line in proc.stderr.splitlines() if "cc1" in line]
    return "\n".join(lines) if proc.returncode == 0 and lines else None


def target_flags(compiler: str | None) -> tuple[str, ...]:
    """``("-march=native",)`` when it is used (see the module docstring), else ``()``."""
    if compiler is None or os.environ.get(PORTABLE_ENV, "") not in ("", "0"):
        return ()
    return ("-march=native",) if _native(compiler) is not None else ()


def signature(compiler: str | None) -> str:
    """What the cache key records of the target: a digest of the native expansion, or
    ``portable``."""
    if not target_flags(compiler):
        return "portable"
    return hashlib.sha256(str(_native(compiler)).encode()).hexdigest()[:16]
