"""A task's own cost terms: ``terms: {TERM: {weight: W, SETTING: value, ...}}`` (issue 25, item 6).

A task file may add registered cost terms (:data:`forte.planning.costs.COST_TERMS`) to every
optimized method it is planned with, with a weight (default: the term's ``default_weight``) and
the settings the term itself declares (:attr:`~forte.planning.costs.CostTerm.settings`: name,
default, unit), e.g. the tip-over term (:mod:`forte.planning.tipover_terms`)::

    terms:
      tipover: {weight: 10, margin: 0.03}     # keep the ZMP 3 cm inside the support polygon

Nothing is added to :class:`~forte.settings.CostWeights`: a setting reaches its term as the
per-waypoint NLP parameter it declares (:func:`term_values`), so the compiled kernels serve every
value; plan.json records the weights (``solver.term_weights``) and the settings in use
(``solver.term_settings``). A term the task names that the method already has keeps its place
and takes the task's weight when one is given.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from forte.planning.costs import COST_TERMS
from forte.planning.schema import Reader
from forte.planning.wrench_terms import term_values as wrench_values
from forte.validation import FloatArray

#: The key of a term's weight in its ``terms:`` entry.
WEIGHT_KEY = "weight"


def terms_section(reader: Reader) -> dict[str, dict[str, float]]:
    """The task's ``terms:`` mapping, checked: registered terms, their declared settings, numbers
    >= 0 (empty when absent)."""
    if not reader.has("terms"):
        return {}
    section = reader.sub("terms")
    out: dict[str, dict[str, float]] = {}
    for name, value in section.data.items():
        if name not in COST_TERMS:
            raise section.error(str(name), f"not a registered cost term; expected one of {', '.join(COST_TERMS)}")
        entry = section.sub(name) if value is not None else Reader({}, reader.path, f"{section.key(name)}.")
        entry.unknown({WEIGHT_KEY} | {s.name for s in COST_TERMS[name].settings})
        out[str(name)] = {key: entry.number(key, nonnegative=True, maximum=1e12) for key in entry.data}
    return out


def with_task_terms(method: Any, terms: dict[str, dict[str, float]]) -> Any:
    """``method`` with the task's terms added (an optimized method; others are returned as is)."""
    if not terms or not method.optimized:
        return method
    added = tuple(name for name in terms if name not in method.terms)
    weights = dict(method.weights) | {name: entry[WEIGHT_KEY] for name, entry in terms.items() if WEIGHT_KEY in entry}
    weights |= {name: COST_TERMS[name].default_weight for name in added if name not in weights}
    return replace(method, terms=(*method.terms, *added), weights=weights)


def term_values(method: Any, force: Any, terms: dict[str, dict[str, float]] | None = None) -> dict[str, FloatArray]:
    """Values of the parameters of ``method``'s terms for a task force and the task's settings:
    the wrench term's moment (:func:`forte.planning.wrench_terms.term_values`) and what each term
    derives itself (:meth:`~forte.planning.costs.CostTerm.task_values`)."""
    values = wrench_values(force)
    if force is None:
        return values
    for name in method.terms:
        values |= COST_TERMS[name].task_values(force, (terms or {}).get(name, {}))
    return values


def term_settings(method: Any, terms: dict[str, dict[str, float]] | None = None) -> dict[str, dict[str, Any]]:
    """The settings in use of ``method``'s terms that declare some (given or default, with units)."""
    out: dict[str, dict[str, Any]] = {}
    for name in method.terms:
        declared = COST_TERMS[name].settings
        if declared:
            given = (terms or {}).get(name, {})
            out[name] = {s.name: {"value": float(given.get(s.name, s.default)), "unit": s.unit, "default": s.default}
                         for s in declared}
    return out
