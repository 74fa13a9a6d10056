"""Input checks shared by every stage: shapes, finiteness and ranges, with precise messages."""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from forte.exceptions import InvalidInputError

FloatArray = NDArray[np.float64]

# Documented upper bounds, checked before anything is allocated from an input (a typo or a
# hostile file must give one line, never exhaust memory).
#: Waypoints of a trajectory (``--waypoints``, ``path.samples``, ``rate`` x duration, CSV rows).
MAX_WAYPOINTS = 2000
#: Duration of a path or a plan, and time stamps, in seconds.
MAX_DURATION_S = 3600.0
#: Seconds simulated after a plan's end (``forte simulate --hold``).
MAX_HOLD_S = 600.0
#: Payload mass accepted as a number (kg); physics decides below this (planning.sanity).
MAX_MASS_KG = 10_000.0
#: Bytes of a task file, plan.json, a CSV or an image read from disk.
MAX_FILE_BYTES = 64 * 2**20
#: Pixels of an image array.
MAX_IMAGE_PIXELS = 50_000_000


def unknown_field(name: str, allowed: Iterable[str]) -> str:
    """``unknown field; expected one of A, B; did you mean 'X'?`` (the closest of ``allowed`` to
    ``name`` by :func:`difflib.get_close_matches`, left out when none is close)."""
    return f"unknown field; expected one of {', '.join(str(a) for a in allowed)}" + did_you_mean(name, allowed)


def did_you_mean(name: Any, allowed: Iterable[Any]) -> str:
    """``; did you mean 'X'?`` with the closest of ``allowed`` to ``name``, or ``""``."""
    close = difflib.get_close_matches(str(name), [str(a) for a in allowed], n=1)
    return f"; did you mean '{close[0]}'?" if close else ""


def reject_bools(value: Any, name: str, _depth: int = 0) -> None:
    """``True``/``False`` are not numbers: raise when ``value`` (or a list inside it) holds one."""
    if isinstance(value, bool | np.bool_):
        raise InvalidInputError(f"{name}: expected a number, got {value!r}")
    if isinstance(value, list | tuple) and _depth < 4:
        for item in value[:10_000]:
            reject_bools(item, name, _depth + 1)


def as_array(value: Any, name: str, shape: tuple[int | None, ...]) -> FloatArray:
    """Return ``value`` as a finite float array of ``shape`` (``None`` = any length).

    Raises:
        InvalidInputError: naming ``name``, the expected and the received shape, or the first
            non-finite entry.
    """
    if isinstance(value, np.ndarray) and value.dtype == np.float64:
        arr = value  # the common case inside forte: no bools to reject, nothing to convert
    else:
        reject_bools(value, name)
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError, OverflowError) as exc:
            raise InvalidInputError(f"{name}: expected numbers, got {_short(value)}") from exc
    if arr.ndim == len(shape) and all(s is None or a == s for a, s in zip(arr.shape, shape, strict=True)) \
            and np.isfinite(arr).all():
        return arr
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
    reject_bools(value, name)
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidInputError(f"{name}: expected a number, got {value!r}") from exc
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise InvalidInputError(f"{name}: expected a finite number {bound}, got {value!r}")
    return x


def payload_mass(value: Any, name: str = "mass", allow_zero: bool = False) -> float:
    """A payload mass in kg: finite, > 0 (>= 0 with ``allow_zero``: no payload) and at most
    :data:`MAX_MASS_KG`; the one check every entry point uses (``InvalidInputError`` naming ``name``)."""
    reject_bools(value, name)
    if not isinstance(value, int | float | np.integer | np.floating):
        raise InvalidInputError(f"{name}: expected a number of kg, got {value!r}")
    x = float(value)
    low = ">= 0" if allow_zero else "> 0"
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero) or x > MAX_MASS_KG:
        raise InvalidInputError(f"{name}: expected a finite number {low} and <= {MAX_MASS_KG:g} kg, got {value!r}")
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


def _short(value: Any, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters (a message stays one readable line)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
