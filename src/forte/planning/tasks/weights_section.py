"""The task file's weights and term settings: the named weight set it starts from
(``weights: {preset: NAME}``), the weights it changes next to it, the term settings given
there under their older names (``weights: {joint_margin: 0.2, dct_cutoff: 0.2, capability_params:
{alpha: 0.8}}``, each term declares its own, :attr:`forte.planning.terms.costs.TermSetting.legacy`) or
in ``terms: {TERM: {SETTING: value}}`` (which wins), and per-joint values given by joint name
(``joint_dof_weights: {panda_joint4: 9}``) turned into the robot's order."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from forte.planning.tasks.schema import Reader, dataclass_from
from forte.planning.tasks.terms_section import read_setting, settings_of, terms_section
from forte.planning.terms.costs import COST_TERMS, TermSetting
from forte.settings import DEFAULT_WEIGHT_SET, WEIGHT_SETS, CostWeights, TermSettings, WeightSet

#: The ``weights:`` key of the capability metric's parameters (the ``capability`` term's settings).
CAPABILITY_PARAMS = "capability_params"


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


def legacy_settings() -> dict[str, tuple[str, TermSetting]]:
    """``weights:`` key -> (term, setting) for every setting declared with an older name."""
    return {s.legacy: (name, s) for name, cls in COST_TERMS.items() if cls.settings_of is None
            for s in cls.settings if s.legacy}


def read_weights(reader: Reader, mode: str, robot: Any) -> WeightSet:
    """The task's weights and term settings: the preset's, with the ``weights:`` fields (weights
    and the settings' older names) and the ``terms:`` settings applied, checked (one line naming
    the file and the field on bad input)."""
    base_names = ("base_x", "base_y", "base_yaw")
    names = (*base_names, *robot.arm_joints)
    by_joint_name(reader, "weights", "joint_dof_weights", names, np.r_[np.zeros(3), np.ones(robot.n_arm)])
    if isinstance(reader.get("terms"), dict) and isinstance(reader.get("terms").get("joint_limits"), dict):
        by_joint_name(reader.sub("terms"), "joint_limits", "dof_weights", names,
                      np.r_[np.zeros(3), np.ones(robot.n_arm)])
    preset = weight_preset(reader, mode)
    legacy = legacy_settings()
    weights, given = preset.weights, {}
    if reader.has("weights"):
        section = reader.sub("weights")
        fields = {f.name for f in dataclasses.fields(CostWeights)}
        section.unknown(fields | set(legacy) | {CAPABILITY_PARAMS})
        plain = {k: v for k, v in section.data.items() if k in fields}
        weights = dataclass_from(Reader({"weights": plain}, reader.path), "weights", CostWeights, preset.weights)
        for key in section.data:
            if key in legacy:
                term, declared = legacy[key]
                given.setdefault(term, {})[declared.name] = read_setting(section, key, declared)
        if CAPABILITY_PARAMS in section.data:
            sub = section.sub(CAPABILITY_PARAMS)
            declared = {s.name: s for s in COST_TERMS["capability"].settings}
            sub.unknown(set(declared))
            given.setdefault("capability", {}).update({k: read_setting(sub, k, declared[k]) for k in sub.data})
    task_terms = settings_of(terms_section(reader))
    settings = preset.settings.merged(given).merged(task_terms)
    dof = settings.get("joint_limits", {}).get("dof_weights")
    where = ("terms.joint_limits", "dof_weights") if "dof_weights" in task_terms.get("joint_limits", {}) else (
        ("weights", "joint_dof_weights") if "dof_weights" in given.get("joint_limits", {}) else None)
    if where is not None and dof is not None and len(dof) != robot.nq:
        raise Reader({}, reader.path, f"{where[0]}.").error(
            where[1], f"expected {robot.nq} values (x, y, yaw and the {robot.n_arm} arm joints), got {len(dof)}")
    return WeightSet(weights, settings)


def weight_preset(reader: Reader, mode: str) -> WeightSet:
    """The weight set named by ``weights.preset`` (default: the mode's, see ``DEFAULT_WEIGHT_SET``)."""
    name = DEFAULT_WEIGHT_SET[mode]
    section = reader.get("weights")
    if isinstance(section, dict) and "preset" in section:
        name = section["preset"]
        if name not in WEIGHT_SETS:
            raise reader.sub("weights").error("preset", f"expected one of {', '.join(WEIGHT_SETS)}, got {name!r}")
    return WEIGHT_SETS[name]


def weights_record(weights: CostWeights, settings: TermSettings) -> dict[str, Any]:
    """plan.json's ``weights`` block: the weights, every setting that has an older ``weights:`` name
    under that name, and the metric's parameters as ``capability_params`` (the shape readers of
    plan.json have relied on; a task file's ``weights:`` section reads it back as is)."""
    record: dict[str, Any] = dataclasses.asdict(weights)
    for key, (term, declared) in legacy_settings().items():
        value = COST_TERMS[term].setting_values(settings)[declared.name]
        record[key] = list(value) if isinstance(value, tuple) else value
    record[CAPABILITY_PARAMS] = dict(COST_TERMS["capability"].setting_values(settings))
    return record


def settings_record(settings: TermSettings) -> dict[str, dict[str, Any]]:
    """plan.json's ``term_settings`` block: every registered term's settings in use (given or
    default), by term (tuples as lists)."""
    return {name: {k: list(v) if isinstance(v, tuple) else v for k, v in cls.setting_values(settings).items()}
            for name, cls in COST_TERMS.items() if cls.settings_of is None and cls.settings}
