"""The task file's weights section: the named weight set it starts from, and per-joint fields given
by joint name (``joint_dof_weights: {panda_joint4: 9}``) turned into the robot's order."""

from __future__ import annotations

from typing import Any

import numpy as np

from forte.planning.schema import Reader
from forte.settings import DEFAULT_WEIGHT_SET, WEIGHT_SETS, CostWeights


def by_joint_name(reader: Reader, block: str, key: str, names: tuple[str, ...], default: Any) -> None:
    """A per-joint field given as ``{joint name: value}`` becomes the list in the robot's order
    (joints left out keep ``default``'s value); a name the robot lacks is an error naming it."""
    section = reader.get(block)
    if not isinstance(section, dict) or not isinstance(section.get(key), dict):
        return
    sub = reader.sub(block)
    given = section[key]
    unknown = sorted(set(given) - set(names))
    if unknown:
        raise sub.error(key, f"no joint named {unknown[0]!r}; the robot's: {', '.join(names)}")
    if default is None:
        missing = [n for n in names if n not in given]
        if missing:
            raise sub.error(key, f"the robot gives no default: name every joint ({', '.join(missing)} missing)")
        default = np.zeros(len(names))
    values = np.array(default, dtype=float).copy()
    for i, name in enumerate(names):
        if name in given:
            values[i] = Reader(given, reader.path, f"{sub.key(key)}.").number(name, nonnegative=True)
    reader.data[block] = {**section, key: values.tolist()}  # the list the dataclass reader checks as usual


def weight_preset(reader: Reader, mode: str) -> CostWeights:
    """The weight set named by ``weights.preset`` (default: the mode's, see ``DEFAULT_WEIGHT_SET``)."""
    name = DEFAULT_WEIGHT_SET[mode]
    section = reader.get("weights")
    if isinstance(section, dict) and "preset" in section:
        name = section["preset"]
        if name not in WEIGHT_SETS:
            raise reader.sub("weights").error("preset", f"expected one of {', '.join(WEIGHT_SETS)}, got {name!r}")
    return WEIGHT_SETS[name]
