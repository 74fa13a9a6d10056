"""What every record forte writes carries: plain JSON values and the versions it ran with.

Plan directories (:mod:`forte.io.plandir`), comparisons (:mod:`forte.io.reports`) and the
experiments' summaries all pass their documents through :func:`jsonable` and record
:func:`package_versions`.
"""

from __future__ import annotations

import platform
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

#: The packages whose versions every record names.
PACKAGES = ("forte", "numpy", "scipy", "casadi", "pin", "example-robot-data", "matplotlib", "mujoco", "openai")


def package_versions() -> dict[str, str]:
    """The Python version and those of :data:`PACKAGES` ("not installed" for one that is absent)."""
    out = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def jsonable(value: Any) -> Any:
    """``value`` with numpy types, paths and non-finite floats turned into plain JSON values."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return str(value)
    if isinstance(value, Path):
        return str(value)
    return value
