"""Methods and cost terms from installed packages: the ``forte.plugins`` entry-point group.

A package adds its methods and terms to forte by declaring, in its ``pyproject.toml``::

    [project.entry-points."forte.plugins"]
    my-methods = "my_package.forte_plugin:register"

where ``register()`` calls :func:`forte.planning.terms.costs.register_term` and
:func:`forte.planning.methods.catalog.register_method`. forte loads every plugin once, the first time the
registry of methods is read (``forte plan --method``'s choices, ``forte compare``,
:func:`~forte.planning.methods.catalog.get_method`), so a plugin's methods appear wherever forte's own do.
A plugin that fails to load or to register is reported in one line on stderr, naming the entry
point, and skipped: it never stops forte.
"""

from __future__ import annotations

import sys
from importlib import metadata

#: The entry-point group forte reads.
PLUGIN_GROUP = "forte.plugins"

_LOADED: dict[str, str] = {}  # entry point name -> "ok" or the error line
_DONE = False


def load_plugins() -> dict[str, str]:
    """Load every ``forte.plugins`` entry point (once per process); returns name -> ``"ok"`` or
    the reason it was skipped."""
    global _DONE
    if _DONE:
        return dict(_LOADED)
    _DONE = True  # first: a plugin that reads the registry while registering must not recurse
    for entry in sorted(metadata.entry_points(group=PLUGIN_GROUP), key=lambda e: e.name):
        try:
            hook = entry.load()
            if callable(hook):
                hook()
            _LOADED[entry.name] = "ok"
        except Exception as exc:  # noqa: BLE001 - a broken plugin is reported and skipped, never fatal
            reason = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}".rstrip(": ")
            _LOADED[entry.name] = reason
            print(f"forte: notice: plugin '{entry.name}' ({entry.value}) skipped: {reason}", file=sys.stderr)
    return dict(_LOADED)
