"""Regenerate the tiny example data set of ``forte bench-mass``: simple drawings and a CSV.

Run ``python examples/massbench/make_dataset.py``. The drawings are schematic (a bottle, a can,
a dumbbell ...) so that the data set is small and can be redistributed. The descriptions say what
a label or a person would (volumes, counts, what the object is) but never its mass, which is what
is estimated. The "true" masses are typical values for such items (contents plus packaging) chosen
by hand, not measurements. This is a smoke test of the pipeline, not the paper's Household test
set (whose ground-truth masses are not distributed): its metrics are not comparable with the
paper's Table 1.
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.patches import Circle, FancyBboxPatch, Rectangle  # noqa: E402

HERE = Path(__file__).resolve().parent
SIZE_PX = 64


def bottle(ax: Axes, x: float, color: str = "#7fb8e6", w: float = 0.22) -> None:
    ax.add_patch(FancyBboxPatch((x, 0.08), w, 0.55, boxstyle="round,pad=0.02", fc=color, ec="k", lw=0.8))
    ax.add_patch(Rectangle((x + w * 0.35, 0.63), w * 0.3, 0.22, fc=color, ec="k", lw=0.8))


def can(ax: Axes, x: float, color: str = "#d62728") -> None:
    ax.add_patch(FancyBboxPatch((x, 0.15), 0.2, 0.45, boxstyle="round,pad=0.02", fc=color, ec="k", lw=0.8))


def draw_two_bottles(ax: Axes) -> None:
    bottle(ax, 0.2)
    bottle(ax, 0.55)


def draw_can(ax: Axes) -> None:
    can(ax, 0.4)


def draw_dumbbell(ax: Axes) -> None:
    ax.add_patch(Rectangle((0.2, 0.45), 0.6, 0.08, fc="#555555"))
    for x in (0.12, 0.72):
        ax.add_patch(Rectangle((x, 0.3), 0.16, 0.38, fc="#222222"))


def draw_beverage_pack(ax: Axes) -> None:
    for x in (0.05, 0.37, 0.69):
        bottle(ax, x, color="#f2a541", w=0.24)


def draw_rice_bag(ax: Axes) -> None:
    ax.add_patch(
        FancyBboxPatch((0.25, 0.1), 0.5, 0.65, boxstyle="round,pad=0.05", fc="#efe6c8", ec="k", lw=0.8)
    )


def draw_wine(ax: Axes) -> None:
    bottle(ax, 0.4, color="#3b5e2b", w=0.2)


def draw_cans(ax: Axes) -> None:
    for x in (0.08, 0.4, 0.72):
        can(ax, x, color="#1f77b4")


def draw_apples(ax: Axes) -> None:
    for x, y in ((0.3, 0.3), (0.55, 0.3), (0.42, 0.55), (0.7, 0.5)):
        ax.add_patch(Circle((x, y), 0.13, fc="#c0392b", ec="k", lw=0.8))


#: image name, drawing, description (never stating the mass), typical true mass (kg).
ITEMS: list[tuple[str, Callable[[Axes], None], str, float]] = [
    ("two_bottles.png", draw_two_bottles, "Carry two 1.5 L bottles of water in the basket.", 3.07),
    ("cola_can.png", draw_can, "Hand over a 330 mL can of cola.", 0.345),
    ("dumbbell.png", draw_dumbbell, "Lift the dumbbell from the rack.", 2.0),
    ("beverage.png", draw_beverage_pack, "Carry the 2.7 L beverage load to the kitchen.", 2.78),
    ("rice_bag.png", draw_rice_bag, "Bring the bag of rice to the table.", 0.51),
    ("wine.png", draw_wine, "Move a 750 mL glass bottle of wine to the shelf.", 1.25),
    ("cans.png", draw_cans, "Carry 3 x 330 mL cans of soda.", 1.04),
    ("apples.png", draw_apples, "Carry the four apples.", 0.9),
]


def draw(path: Path, painter: Callable[[Axes], None]) -> None:
    fig = plt.figure(figsize=(1, 1), dpi=SIZE_PX)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.axis("off")
    fig.patch.set_facecolor("white")
    painter(ax)
    fig.savefig(path, dpi=SIZE_PX, facecolor="white")
    plt.close(fig)


def main() -> None:
    (HERE / "images").mkdir(exist_ok=True)
    for name, painter, _, _ in ITEMS:
        draw(HERE / "images" / name, painter)
    with (HERE / "dataset.csv").open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["image", "description", "mass_kg"])
        for name, _, description, mass in ITEMS:
            writer.writerow([f"images/{name}", description, mass])
    print(f"wrote {len(ITEMS)} images and {HERE / 'dataset.csv'}")


if __name__ == "__main__":
    main()
