"""The paper's claims and how our runs judge them.

Rules for judging a claim of the paper (:class:`Claim`):

* A claim is a list of :class:`Check` s, each a condition with the number(s) it was judged on.
  It is reproduced only if it has at least one check and every check holds; no evidence is
  never a reproduction.
* A claim about a plan needs that plan to be a solution (:func:`solved`): the metrics of a
  failed solve are those of the solver's last iterate, not of a plan.
* A claim about simulation outcomes must hold in *every* run: the nominal run and each seeded
  mass-error trial (:func:`every_run`). Only a claim that itself says "in some trials" (the
  paper's "one of the three trials failed") is judged on "at least one run"
  (:func:`some_run_fails`), and its evidence lists every run.
* A claim that a plan *fails under the load* also needs the same plan to succeed without
  payload (:func:`unloaded_succeeds`): otherwise the failure comes from the motion.
* The claims table holds the paper's claims only. What is our own observation (an issue's
  test, an implied property, a remark on our model) goes into the summary's notes.
* A claim that is not reproduced states its numbers and a cause: the checks that failed, each
  with its evidence.
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from forte.planning.planner import Plan


def fmt_num(value: Any, digits: int = 2) -> str:
    """A number for a table ("-" for None)."""
    if value is None:
        return "-"
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def cell(text: str) -> str:
    """Text for a markdown table cell."""
    return text.replace("|", "\\|")


@dataclass
class Case:
    """The plans of one payload (or of the force profile) and their simulations: what the claims
    about it are judged on (:func:`every_run`, :func:`some_run_fails`)."""

    label: str
    mass: float | None
    results: dict[str, Plan] = field(default_factory=dict)
    sims: dict[str, dict[str, Any]] = field(default_factory=dict)


@dataclass(frozen=True)
class Check:
    """One condition of a claim: what must hold, whether it does, and the measured evidence."""

    what: str
    ok: bool
    evidence: str


@dataclass
class Claim:
    """One claim of the paper and the checks our run judges it by (rules: module docstring)."""

    section: str
    claim: str
    measure: str
    ours: str
    checks: list[Check] = field(default_factory=list)
    #: Our analysis of why the claim does not hold on our model (numbers from the same run),
    #: printed after the failing checks when it is not reproduced.
    why: str = ""

    @property
    def reproduced(self) -> bool:
        """Every check holds (and there is at least one)."""
        return bool(self.checks) and all(c.ok for c in self.checks)

    @property
    def cause(self) -> str | None:
        """Why the claim is not reproduced: the failing checks with their evidence (None if it is)."""
        if self.reproduced:
            return None
        if not self.checks:
            return "nothing was measured"
        failing = "; ".join(f"expected {c.what}, got {c.evidence}" for c in self.checks if not c.ok)
        return f"{failing}. Why: {self.why}" if self.why else failing

    def to_json(self) -> dict[str, Any]:
        return {"section": self.section, "claim": self.claim, "measure": self.measure, "ours": self.ours,
                "reproduced": self.reproduced, "cause": self.cause, "checks": [vars(c) for c in self.checks]}

    def row(self) -> str:
        verdict = "yes" if self.reproduced else "**no**"
        cells = [cell(c) for c in (self.section, self.claim, self.measure, self.ours)]
        return "| " + " | ".join([*cells, verdict]) + " |"


_OPS: dict[str, Callable[[Any, Any], Any]] = {">": operator.gt, ">=": operator.ge, "<": operator.lt,
                                               "<=": operator.le}
_SYMBOLS = {">": ">", ">=": "≥", "<": "<", "<=": "≤"}


def compare(left: str, value: float, op: str, right: str, bound: float, unit: str = "", digits: int = 1) -> Check:
    """``value op bound`` as a check; e.g. ``compare("forte's capacity", 41.0, ">=", "|f| + r", 36.5, " N")``.

    A non-finite value never passes.
    """
    ok = bool(np.isfinite(value) and np.isfinite(bound) and _OPS[op](value, bound))
    return Check(f"{left} {_SYMBOLS[op]} {right}", ok, f"{value:.{digits}f} vs {bound:.{digits}f}{unit}")


def solved(results: dict[str, Plan], *methods: str) -> Check:
    """The plans of ``methods`` are solutions (a failed solve's metrics are its last iterate's)."""
    missing = [m for m in methods if m not in results]
    failed = [m for m in methods if m in results and not results[m].solved]
    evidence = "; ".join([*(f"{m}: {results[m].status}" for m in failed), *(f"{m}: not planned" for m in missing)])
    return Check(f"{', '.join(methods)} planned successfully", not (failed or missing), evidence or "all solved")


def runs(sim: dict[str, Any] | None, mass: float | None = None) -> list[dict[str, Any]]:
    """The simulated runs of one plan: the nominal run first, then each mass-error trial."""
    if not sim or sim.get("verdict") not in ("success", "failure"):
        return []
    nominal = {"label": "nominal", "mass": mass, "success": sim["verdict"] == "success", "reason": sim.get("reason"),
               "failure_time": sim.get("failure_time")}
    trials = (sim.get("trials") or {}).get("runs", [])
    return [nominal, *({"label": f"trial {i + 1}", **r} for i, r in enumerate(trials))]


def run_text(run: dict[str, Any]) -> str:
    """``LABEL (MASS kg): ok`` or ``LABEL (MASS kg): REASON at TIME s`` for one simulated run."""
    mass = "" if run.get("mass") is None else f" ({run['mass']:.3g} kg)"
    outcome = "ok" if run["success"] else f"{run['reason']} at {fmt_num(run['failure_time'])} s"
    return f"{run['label']}{mass}: {outcome}"


def _no_runs(sim: dict[str, Any] | None) -> str:
    return "not simulated" + (f" ({sim['reason']})" if sim and sim.get("reason") else "")


def every_run(case: Case, method: str, success: bool = True) -> Check:
    """``method`` succeeds (or, with ``success=False``, fails) in every simulated run of ``case``.

    A success also needs the plan's verdict to be ``feasible`` (:mod:`forte.planning.verdict.verdict`): a
    run that happens to get through with a plan short of its requirements is not counted."""
    verb = "succeeds" if success else "fails"
    what = f"{method} {verb} in every run (nominal + mass-error trials)" + (" with a feasible plan" if success else "")
    done = runs(case.sims.get(method), case.mass)
    if not done:
        return Check(what, False, _no_runs(case.sims.get(method)))
    odd = [r for r in done if r["success"] != success]
    evidence = f"{len(done) - len(odd)}/{len(done)} runs {'ok' if success else 'failed'}"
    if odd:
        evidence += "; " + "; ".join(run_text(r) for r in odd)
    res = case.results.get(method)
    infeasible = success and res is not None and not res.feasible
    if infeasible:
        evidence += f"; plan {res.label} ({res.verdict.brief() if res.verdict is not None else 'not judged'})"
    return Check(what, not odd and not infeasible, evidence)


def some_run_fails(case: Case, method: str) -> Check:
    """``method`` fails in at least one simulated run of ``case`` (for claims about "some trials")."""
    what = f"{method} fails in at least one run"
    done = runs(case.sims.get(method), case.mass)
    if not done:
        return Check(what, False, _no_runs(case.sims.get(method)))
    failed = [r for r in done if not r["success"]]
    evidence = f"{len(failed)}/{len(done)} runs failed" + ("; " + "; ".join(run_text(r) for r in failed)
                                                            if failed else "")
    return Check(what, bool(failed), evidence)


def unloaded_succeeds(unloaded: dict[str, dict[str, Any]], method: str) -> Check:
    """The plan runs without payload, so a failure with the payload comes from the load."""
    run = unloaded.get(method)
    what = f"{method} succeeds without payload"
    if run is None:
        return Check(what, False, "not simulated without payload")
    return Check(what, bool(run["success"]), "ok" if run["success"] else run_text(run))


def across_trials(per_trial: list[list[Claim]]) -> list[Claim]:
    """Claims judged on repeated plannings: each is reproduced only if it is in every trial.

    ``per_trial[i]`` are the claims of planning trial ``i``, in the same order for every trial;
    the result keeps trial 1's texts and joins every trial's checks (tagged ``trial i``).
    """
    if len(per_trial) <= 1:
        return per_trial[0] if per_trial else []
    merged = []
    for versions in zip(*per_trial, strict=True):
        held = sum(v.reproduced for v in versions)
        checks = [replace(c, what=f"{c.what} in planning trial {i + 1}")
                  for i, v in enumerate(versions) for c in v.checks]
        merged.append(replace(versions[0], ours=f"{versions[0].ours} (planning trial 1; holds in {held}/"
                              f"{len(versions)} trials)", checks=checks))
    return merged


def claims_section(claims: list[Claim]) -> list[str]:
    """The claims table, then one cause line per claim that is not reproduced."""
    done = sum(c.reproduced for c in claims)
    lines = [f"## Paper claim vs our result ({done}/{len(claims)} reproduced)", "",
             "| § | paper claim | our measure | our result | reproduced |", "|---|---|---|---|---|",
             *[c.row() for c in claims], ""]
    failed = [c for c in claims if not c.reproduced]
    if failed:
        lines += ["### Not reproduced: why", "",
                  *[f"- §{c.section} {c.claim}: ours {c.ours}. Cause: {c.cause}." for c in failed], ""]
    return lines


