"""A new cost term and a new method enter through the registries alone and plan end to end."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import ClassVar

import casadi as ca
import numpy as np
import pytest

from forte.cli.main import build_parser
from forte.exceptions import InvalidInputError
from forte.planning.methods.catalog import (
    METHODS,
    Method,
    MethodStyle,
    method_names,
    register_method,
    unregister_method,
)
from forte.planning.nlp.kernels import kernel_key
from forte.planning.planner import methods_for, plan
from forte.planning.tasks.tasks import load_task
from forte.planning.terms.costs import COST_TERMS, CostTerm, Stage, register_term
from forte.settings import TermSettings

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


@dataclass(frozen=True)
class BaseDistance(CostTerm):
    """Toy stage term: ``c_k = ||(x_k, y_k) - centre||^2``, keeps the base near ``centre``."""

    name: ClassVar[str] = "base_distance"
    default_weight: ClassVar[float] = 1.0
    centre: tuple[float, float] = (0.0, 0.0)

    def stage(self, s: Stage) -> ca.SX:
        return ca.sumsqr(s.q0[:2] - ca.DM(self.centre))


@pytest.fixture
def toy_method():
    register_term(BaseDistance, replace=True)
    method = register_method(Method(
        "toy", "forte plus a pull of the base towards the origin",
        terms=(*METHODS["forte"].terms, "base_distance"), weights={"base_distance": 200.0},
        style=MethodStyle("tab:olive", "toy"),
    ), replace=True)
    yield method
    unregister_method("toy")
    COST_TERMS.pop("base_distance", None)


def test_new_term_and_method_plan_through_the_registries(toy_method, tmp_path):
    task = load_task(LIFT, waypoints=12)
    assert "toy" in methods_for(task) and "toy" in method_names(optimized=True)
    # the toy's pull (weight 200 towards the origin, on a lift that ends 1.06 m out) makes IPOPT
    # cycle between two iterates for hundreds of iterations once the executed spline's rows are in
    # the NLP (limits.on_spline): 715 iterations to the optimum it reaches in 33 without them (the
    # same objective, 251.022; the rows stay inactive there, the spline within 0.42 x every limit).
    # The registries are under test here, not IPOPT's path: room for that many iterations.
    task = replace(task, solver=replace(task.solver, max_iter=2000))
    toy = plan(task, "toy")
    assert toy.solved, toy.status
    terms = toy.solver["cost_terms"]
    assert set(terms) == {*METHODS["forte"].terms, "base_distance"}
    # the compiled term equals the formula evaluated on the plan
    assert terms["base_distance"] == pytest.approx(float(np.sum(toy.q[:, :2] ** 2)), rel=1e-9, abs=1e-12)
    assert toy.solver["term_weights"]["base_distance"] == 200.0
    reference = plan(task, "forte")
    assert np.sum(toy.q[:, :2] ** 2) < np.sum(reference.q[:, :2] ** 2)
    # the CLI offers it without any edit
    parser = build_parser()
    args = parser.parse_args(["plan", str(LIFT), "--method", "toy", "--out", str(tmp_path / "toy")])
    assert args.method == "toy"


def test_what_a_term_bakes_in_is_part_of_the_kernel_key(toy_method, robot):

    base = kernel_key(robot, "toy")
    moved = Method("toy2", "", terms=("base_distance",))
    register_method(moved)
    try:
        assert kernel_key(robot, "toy2") != base
        # changing a baked parameter of a built-in term changes the key; a runtime weight does not
        assert kernel_key(robot, "forte", TermSettings({"capability": {"beta": 20.0}})) != kernel_key(robot, "forte")
        # a term's baked settings are in the key, an NLP-parameter setting (tipover's margin) is not
        assert kernel_key(robot, "forte", TermSettings({"joint_limits": {"margin_fraction": 0.1}})) != kernel_key(
            robot, "forte")
        assert kernel_key(robot, "forte", TermSettings({"tipover": {"margin": 0.05}})) == kernel_key(robot, "forte")
    finally:
        unregister_method("toy2")


def test_registry_errors_are_one_line():
    with pytest.raises(InvalidInputError, match="cost term 'nope': not registered"):
        Method("bad", "", terms=("nope",))
    with pytest.raises(InvalidInputError, match="already registered"):
        register_method(METHODS["forte"])
    with pytest.raises(InvalidInputError, match="needs produce"):
        Method("bad", "", production="given")
    with pytest.raises(InvalidInputError, match="method: expected one of"):
        plan(load_task(LIFT, waypoints=5), "no-such-method")


def test_every_method_has_a_distinct_colour_and_label():
    styles = [m.style for m in METHODS.values()]
    assert len({s.color for s in styles}) == len(styles)
    assert all(s.label for s in styles)


def test_registry_rejects_what_would_load_stale_kernels_or_escape_the_cache():
    class Loose(CostTerm):  # not a frozen dataclass: its state would not be in the cache key
        name: ClassVar[str] = "loose"

    with pytest.raises(InvalidInputError, match="frozen dataclass"):
        register_term(Loose)
    with pytest.raises(InvalidInputError, match="method name"):
        Method("../escape", "", terms=("manipulability",))
    with pytest.raises(InvalidInputError, match="weights: 'capabilty' is not one of its terms"):
        Method("typo", "", terms=("capability",), weights={"capabilty": 3.0})


def test_baked_arrays_enter_the_key_exactly(robot):
    @dataclass(frozen=True)
    class Offset(CostTerm):
        name: ClassVar[str] = "offset_toy"
        offset: tuple[float, ...] = (0.0,)

        def stage(self, s: Stage) -> ca.SX:
            return ca.sumsqr(s.q0[:1] - self.offset[0])

    a, b = Offset((0.123456789012,)), Offset((0.123456789013,))
    assert a.baked() != b.baked()  # 1e-12 apart: different kernels


def test_a_method_object_that_is_not_registered_plans_too():
    task = load_task(LIFT, waypoints=5)
    custom = Method("unregistered-manip", "", terms=("manipulability", "joint_limits"))
    assert plan(task, custom).method == "unregistered-manip"
