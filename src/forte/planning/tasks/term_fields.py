"""The task file's ``weights:`` and ``terms:`` fields, from their owners: the weight sets
(:data:`forte.settings.WEIGHT_SETS`), the weights (:class:`forte.settings.CostWeights`) and each
registered cost term's declared settings (:class:`forte.planning.terms.costs.TermSetting`)."""

from __future__ import annotations

import dataclasses
import re
from typing import Any

from forte.planning.tasks.task_types import (
    BOOL,
    MAPPING,
    Field,
    Prose,
    Type,
    choice,
    integer,
    joint_values,
    nullable,
    number,
    vector,
)
from forte.planning.tasks.weights_section import CAPABILITY_PARAMS, legacy_settings
from forte.planning.terms.costs import COST_TERMS, TermSetting
from forte.settings import DEFAULT_WEIGHT_SET, WEIGHT_SETS, CostWeights

#: Settings that may also be given by joint name (``{joint: value}``; the reader puts them in order).
JOINT_NAMED = frozenset({("joint_limits", "dof_weights")})
#: What a term's weight may be (the reader's bound).
WEIGHT = number(low=0, high=1e12)


def _bounds(expected: str) -> dict[str, float]:
    """Bounds stated in a setting's ``expected`` words (``a finite number >= 0``, ``0 < x <= 1``)."""
    m = re.fullmatch(r"(?:a finite number|an integer|(?:\d+ )?finite numbers) (>=|>) ([\d.]+)", expected)
    if m:
        return {"low" if m[1] == ">=" else "above": float(m[2])}
    m = re.fullmatch(r"([\d.]+) < \w+ (<=|<) ([\d.]+)", expected)
    if m:
        return {"above": float(m[1]), "high" if m[2] == "<=" else "below": float(m[3])}
    return {}


def setting_type(term: str, s: TermSetting) -> Type:
    """The type of a declared setting, from its ``kind`` and the bounds its ``expected`` words state."""
    kind = s.kind.removesuffix(" | None")
    bounds = _bounds(s.expected)
    if kind == "bool":
        t = BOOL
    elif kind == "str":
        names = re.split(r", | or ", s.expected.removeprefix("one of "))
        t = choice([n for n in names if n != "null"])
    elif kind == "int":
        t = integer(int(bounds.get("low", 0)), 10**9)
    elif kind == "vector":
        size = len(s.default) if isinstance(s.default, tuple) and s.expected.startswith(f"{len(s.default)} ") else None
        t = vector(size, low=bounds.get("low"), above=bounds.get("above"))
        if (term, s.name) in JOINT_NAMED:
            t = joint_values(low=bounds.get("low"), above=bounds.get("above"))
    else:
        t = number(**bounds)
    t = Type(t.words, t.schema, s.expected)
    return nullable(t) if s.kind.endswith("| None") else t


def _default(value: Any) -> Any:
    if value is None:
        return Prose("null")
    return list(value) if isinstance(value, tuple) else value


def _unit(unit: str) -> str:
    return "" if unit == "1" else unit


def weights_fields() -> list[Field]:
    """``weights:``: the named set, its weights, the settings' older names, ``capability_params``."""
    modes = ", ".join(f"{name} ({mode})" for mode, name in DEFAULT_WEIGHT_SET.items())
    out = [Field("weights.preset", choice(tuple(WEIGHT_SETS)), "the named weight set the task starts from",
                 default=Prose(modes))]
    out += [Field(f"weights.{f.name}", WEIGHT, f"weight of the {f.name} term", default=Prose("the set's"))
            for f in dataclasses.fields(CostWeights) if f.name != "preset"]
    for key, (term, s) in legacy_settings().items():
        out.append(Field(f"weights.{key}", setting_type(term, s), f"older name of terms.{term}.{s.name}: {s.doc}",
                         _unit(s.unit), _default(s.default)))
    out.append(Field(f"weights.{CAPABILITY_PARAMS}", MAPPING, "older place of the capability term's settings"))
    out += [Field(f"weights.{CAPABILITY_PARAMS}.{s.name}", setting_type("capability", s), s.doc, _unit(s.unit),
                  _default(s.default)) for s in COST_TERMS["capability"].settings]
    return out


def term_fields() -> list[Field]:
    """``terms:``: every registered cost term, its weight and its declared settings."""
    out: list[Field] = []
    for name, cls in COST_TERMS.items():
        summary = (cls.__doc__ or name).strip().split("\n\n")[0].replace("\n", " ")
        out.append(Field(f"terms.{name}", nullable(MAPPING), summary.split(". ")[0].rstrip(".")))
        out.append(Field(f"terms.{name}.weight", WEIGHT, "the term's weight",
                         default=Prose(f"the set's, else {cls.default_weight:g}")))
        for s in cls.settings if cls.settings_of is None else ():
            out.append(Field(f"terms.{name}.{s.name}", setting_type(name, s), s.doc, _unit(s.unit),
                             _default(s.default)))
    return out
