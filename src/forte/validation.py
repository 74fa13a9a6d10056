"""Input checks shared by every stage: shapes, finiteness and ranges, with precise messages."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from forte.exceptions import InvalidInputError

FloatArray = NDArray[np.float64]


def as_array(value: Any, name: str, shape: tuple[int | None, ...]) -> FloatArray:
    """Return ``value`` as a finite float array of ``shape`` (``None`` = any length).

    Raises:
        InvalidInputError: naming ``name``, the expected and the received shape, or the first
            non-finite entry.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name}: expected numbers, got {value!r}") from exc
    dims = tuple("N" if s is None else str(s) for s in shape)
    expected = "(" + ", ".join(dims) + ("," if len(dims) == 1 else "") + ")"
    if arr.ndim != len(shape) or any(
        s is not None and a != s for a, s in zip(arr.shape, shape, strict=True)
    ):
        raise InvalidInputError(f"{name}: expected shape {expected}, got {arr.shape}")
    bad = np.argwhere(~np.isfinite(arr))
    if bad.size:
        index = tuple(int(i) for i in bad[0])
        where = f"[{', '.join(map(str, index))}]" if index else ""
        raise InvalidInputError(f"{name}{where}: expected a finite number, got {arr[tuple(bad[0])]}")
    return arr


def as_vector(value: Any, name: str, size: int) -> FloatArray:
    """A finite 1-D array of exactly ``size`` entries."""
    return as_array(value, name, (size,))


def as_positive(value: Any, name: str, allow_zero: bool = False) -> float:
    """A finite scalar > 0 (or >= 0 with ``allow_zero``)."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name}: expected a number, got {value!r}") from exc
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise InvalidInputError(f"{name}: expected a finite number {bound}, got {value!r}")
    return x


def check_times(t: Any, name: str = "t") -> FloatArray:
    """Strictly increasing finite time stamps; names the first offending sample."""
    times = as_array(t, name, (None,))
    if times.size < 1:
        raise InvalidInputError(f"{name}: expected at least one time stamp")
    steps = np.diff(times)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise InvalidInputError(
            f"{name}[{k}]: time stamps must be strictly increasing, "
            f"got {times[k - 1]} then {times[k]}"
        )
    return times
