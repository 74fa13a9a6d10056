"""A task's cost terms: ``terms: {TERM: {weight: W, SETTING: value, ...}}`` (issue 25, item 6).

A task file sets the settings a term declares itself (:attr:`~forte.planning.terms.costs.CostTerm.settings`:
name, default, unit, check) and may add registered cost terms
(:data:`forte.planning.terms.costs.COST_TERMS`) to every optimized method it is planned with, with a
weight (default: the term's ``default_weight``), e.g. the tip-over term
(:mod:`forte.planning.terms.tipover_terms`) or the manipulability term's regularization::

    terms:
      tipover: {weight: 10, margin: 0.03}     # keep the ZMP 3 cm inside the support polygon
      manipulability: {lambda: 1.0e-4}       # a setting of a term the method already has

The settings join the weight set's (:class:`~forte.settings.TermSettings`, ``Task.settings``):
an NLP-parameter setting reaches its term per waypoint (:func:`term_values`), so the compiled
kernels serve every value; a baked one (most of the paper's terms') is compiled into the kernels
and part of their cache key. plan.json records the weights (``solver.term_weights``) and every
setting in use with its unit and default (``solver.term_settings``). A term the task names that
the method already has keeps its place and takes the task's weight when one is given.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from forte.exceptions import InvalidInputError
from forte.planning.tasks.schema import Reader
from forte.planning.terms.costs import COST_TERMS, TermSetting
from forte.planning.terms.wrench_terms import term_values as wrench_values
from forte.validation import FloatArray, did_you_mean

#: The key of a term's weight in its ``terms:`` entry.
WEIGHT_KEY = "weight"


def terms_section(reader: Reader) -> dict[str, dict[str, Any]]:
    """The task's ``terms:`` mapping, checked: registered terms, their declared settings (each by
    its own check), weights numbers >= 0 (empty when absent)."""
    if not reader.has("terms"):
        return {}
    section = reader.sub("terms")
    out: dict[str, dict[str, Any]] = {}
    for name, value in section.data.items():
        if name not in COST_TERMS:
            raise section.error(str(name), f"not a registered cost term; expected one of {', '.join(COST_TERMS)}"
                                + did_you_mean(name, COST_TERMS))
        entry = section.sub(name) if value is not None else Reader({}, reader.path, f"{section.key(name)}.")
        declared = {s.name: s for s in COST_TERMS[name].settings} if COST_TERMS[name].settings_of is None else {}
        entry.unknown({WEIGHT_KEY} | set(declared))
        out[str(name)] = {key: entry.number(key, nonnegative=True, maximum=1e12) if key == WEIGHT_KEY
                          else read_setting(entry, key, declared[key]) for key in entry.data}
    return out


def read_setting(reader: Reader, key: str, declared: TermSetting) -> Any:
    """``reader[key]`` as the value of the setting ``declared`` (a list becomes a tuple of floats),
    checked by the setting; a bad value is one line naming the file, the key and what is expected."""
    value = reader.get(key)
    if isinstance(value, list) and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value):
        value = tuple(float(v) for v in value)
    elif isinstance(value, int) and not isinstance(value, bool) and declared.kind.startswith("float"):
        value = float(value)
    try:
        return declared.check(value)
    except InvalidInputError:
        raise reader.error(key, f"expected {declared.expected}, got {value!r}") from None


def settings_of(terms: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """The settings in a task's ``terms:`` mapping (its weights left out)."""
    return {name: {k: v for k, v in entry.items() if k != WEIGHT_KEY} for name, entry in terms.items()}


def with_task_terms(method: Any, terms: dict[str, dict[str, float]]) -> Any:
    """``method`` with the task's terms added (an optimized method; others are returned as is)."""
    if not terms or not method.optimized:
        return method
    added = tuple(name for name in terms if name not in method.terms)
    weights = dict(method.weights) | {name: entry[WEIGHT_KEY] for name, entry in terms.items() if WEIGHT_KEY in entry}
    weights |= {name: COST_TERMS[name].default_weight for name in added if name not in weights}
    return replace(method, terms=(*method.terms, *added), weights=weights)


def term_values(method: Any, force: Any, terms: Mapping[str, Mapping[str, Any]] | None = None
                ) -> dict[str, FloatArray]:
    """Values of the parameters of ``method``'s terms for a task force and the task's settings:
    the wrench term's moment (:func:`forte.planning.terms.wrench_terms.term_values`) and what each term
    derives itself (:meth:`~forte.planning.terms.costs.CostTerm.task_values`)."""
    values = wrench_values(force)
    if force is None:
        return values
    for name in method.terms:
        values |= COST_TERMS[name].task_values(force, (terms or {}).get(name, {}))
    return values


def term_settings(method: Any, terms: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, dict[str, Any]]:
    """The settings in use of ``method``'s terms that declare some (given or default, with units),
    by the owning term (the baselines' capability terms report ``capability``'s)."""
    out: dict[str, dict[str, Any]] = {}
    for name in method.terms:
        cls = COST_TERMS[COST_TERMS[name].settings_of or name]
        if cls.settings and cls.name not in out:
            given = cls.setting_values(terms)
            out[cls.name] = {s.name: {"value": _json(given[s.name]), "unit": s.unit, "default": _json(s.default)}
                             for s in cls.settings}
    return out


def _json(value: Any) -> Any:
    """A setting's value as JSON writes it (a tuple as a list, a number as a float)."""
    if isinstance(value, tuple):
        return [float(v) for v in value]
    if isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    return value
