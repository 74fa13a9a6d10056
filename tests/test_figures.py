"""Figures: every format, method colours from the registry, the force ball's slice, grouped hold bars."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from forte.exceptions import InvalidInputError
from forte.io.figures import figure_format, plan_figures, plot_comparison, pyplot, slice_polygon, style
from forte.planning.methods import METHODS
from forte.planning.planner import plan
from forte.planning.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


@pytest.fixture(scope="module")
def quintic():
    return plan(load_task(LIFT, waypoints=8), "quintic")


@pytest.mark.parametrize("fmt", ["png", "pdf", "svg"])
def test_plan_figures_in_each_format(quintic, tmp_path: Path, fmt: str) -> None:
    with figure_format(fmt):
        plan_figures(quintic, tmp_path)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == sorted(f"{s}.{fmt}" for s in ("capacity", "manipulability", "rfp_worst", "ellipsoid"))
    head = (tmp_path / f"capacity.{fmt}").read_bytes()[:8]
    assert head.startswith({"png": b"\x89PNG", "pdf": b"%PDF", "svg": b"<?xml"}[fmt])


def test_unknown_format_is_refused() -> None:
    with pytest.raises(InvalidInputError, match="--format: expected one of png, pdf, svg"), figure_format("jpg"):
        pass


def test_colours_come_from_the_registry() -> None:
    for name, method in METHODS.items():
        assert style(name) == (method.style.color, method.style.label)


def test_slice_of_a_box() -> None:
    A = np.vstack([np.eye(3), -np.eye(3)])
    b = np.array([1.0, 2.0, 3.0, 1.0, 2.0, 3.0])
    poly = slice_polygon(A, b, np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 0, 1.0]))
    assert sorted(map(tuple, np.round(poly, 9))) == [(-1, -3), (-1, 3), (1, -3), (1, 3)]


def test_hold_comparison_has_no_joining_lines(quintic, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    task = load_task(Path(__file__).resolve().parents[1] / "examples" / "tasks" / "hold.yaml")
    results = [plan(task, "teaching")]
    results.append(results[0])
    plt = pyplot()
    figures = []
    monkeypatch.setattr(plt, "close", figures.append)
    plot_comparison(results, tmp_path / "comparison.png")
    (fig,) = figures
    for ax in fig.axes:
        for line in ax.get_lines():  # only horizontal reference lines, no line through categories
            assert np.ptp(np.asarray(line.get_ydata(), dtype=float)) == 0
