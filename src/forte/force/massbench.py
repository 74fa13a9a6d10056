"""Mass-estimation benchmark with the Image2Mass metrics (paper, Section 5.1, Table 1).

For an estimate ``m_hat`` of a true mass ``m`` (both in kg), per item:

* ``ALDE  = |ln m_hat - ln m|``                    (absolute log difference error, lower is better)
* ``APE   = |m_hat - m| / m``                      (absolute percentage error, lower is better)
* ``MnRE  = min(m_hat / m, m / m_hat)``            (min ratio, in (0, 1], higher is better)
* ``q_i   = 1 if max(m_hat / m, m / m_hat) < 2``   (within a factor of two, higher is better)

and over the set: ``mALDE``, ``mAPE``, ``mMnRE``, ``q`` are the means of the above and
``r2_ls = corr(ln m, ln m_hat)^2``, the squared Pearson correlation of the log masses.

Uncertainty is reported as +-2 standard errors: ``2 s / sqrt(n)`` with ``s`` the sample standard
deviation (ddof = 1) for the four means, and ``2 x`` the bootstrap standard deviation of
``r2_ls`` over items resampled with replacement (seeded, 1000 resamples by default).

Honesty rules: a row whose description states a mass ("a 2 kg dumbbell") gives the answer away,
so such rows are counted and flagged in the report (:func:`states_mass`); and the paper's rows
are printed in a table of their own, marked as measured on another data set with another
estimator, never next to ours as if comparable.
"""

from __future__ import annotations

import csv
import math
import sys
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from forte.exceptions import ForteError, InvalidInputError
from forte.force.mass import MassEstimate, MassEstimator
from forte.force.quantities import states_mass

METRICS: tuple[str, ...] = ("mALDE", "mAPE", "r2_ls", "mMnRE", "q")
#: Direction of improvement of each metric (for the table header).
ARROWS: dict[str, str] = {"mALDE": "↓", "mAPE": "↓", "r2_ls": "↑", "mMnRE": "↑", "q": "↑"}

#: Rows of the paper's Table 1, measured on the Image2Mass Household test set (56 items / 423
#: images) with GPT-4o; the Image2Mass rows come from the Image2Mass paper. Not comparable with a
#: run on another data set.
PAPER_ROWS: dict[str, dict[str, float]] = {
    "Image2Mass (single-view)": {"mALDE": 0.465, "mAPE": 0.685, "r2_ls": 0.691, "mMnRE": 0.675, "q": 0.766},
    "Image2Mass (multi-view)": {"mALDE": 0.437, "mAPE": 0.637, "r2_ls": 0.701, "mMnRE": 0.693, "q": 0.786},
    "Paper, GPT-4o (single-view)": {
        "mALDE": 0.333,
        "mAPE": 0.377,
        "r2_ls": 0.839,
        "mMnRE": 0.742,
        "q": 0.917,
    },
}


def _pair(pred: Any, true: Any) -> tuple[np.ndarray, np.ndarray]:
    p = np.asarray(pred, dtype=float)
    t = np.asarray(true, dtype=float)
    if p.shape != t.shape or p.ndim != 1:
        raise InvalidInputError(
            f"pred, true: expected two 1-D arrays of one length, got {p.shape}, {t.shape}"
        )
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(t)) and np.all(p > 0) and np.all(t > 0)):
        raise InvalidInputError("pred, true: expected finite positive masses")
    return p, t


def alde(pred: Any, true: Any) -> np.ndarray:
    """``|ln m_hat - ln m|`` per item."""
    p, t = _pair(pred, true)
    return np.abs(np.log(p) - np.log(t))


def ape(pred: Any, true: Any) -> np.ndarray:
    """``|m_hat - m| / m`` per item."""
    p, t = _pair(pred, true)
    return np.abs(p - t) / t


def mnre(pred: Any, true: Any) -> np.ndarray:
    """``min(m_hat / m, m / m_hat)`` per item."""
    p, t = _pair(pred, true)
    return np.minimum(p / t, t / p)


def within_factor_two(pred: Any, true: Any) -> np.ndarray:
    """``1.0`` where ``max(m_hat / m, m / m_hat) < 2``, else ``0.0``."""
    p, t = _pair(pred, true)
    return (np.maximum(p / t, t / p) < 2.0).astype(float)


def r2_ls(pred: Any, true: Any) -> float:
    """``corr(ln m, ln m_hat)^2``; NaN with fewer than 2 items or a constant log mass."""
    p, t = _pair(pred, true)
    if p.size < 2:
        return math.nan
    x, y = np.log(t), np.log(p)
    x, y = x - x.mean(), y - y.mean()
    denom = math.sqrt(float(x @ x) * float(y @ y))
    if denom == 0.0:
        return math.nan
    return float((x @ y) / denom) ** 2


def _two_se(values: np.ndarray) -> float:
    return 2.0 * float(values.std(ddof=1)) / math.sqrt(values.size) if values.size > 1 else math.nan


def summarize(pred: Any, true: Any, n_boot: int = 1000, seed: int = 0) -> dict[str, tuple[float, float]]:
    """Each metric of :data:`METRICS` as ``(value, 2 standard errors)`` (see the module docstring)."""
    p, t = _pair(pred, true)
    if p.size == 0:
        return {name: (math.nan, math.nan) for name in METRICS}
    per_item = {
        "mALDE": alde(p, t),
        "mAPE": ape(p, t),
        "mMnRE": mnre(p, t),
        "q": within_factor_two(p, t),
    }
    out = {name: (float(v.mean()), _two_se(v)) for name, v in per_item.items()}
    r2 = r2_ls(p, t)
    boot: list[float] = []
    if p.size > 2 and not math.isnan(r2):
        rng = np.random.default_rng(seed)
        for _ in range(n_boot):
            idx = rng.integers(0, p.size, p.size)
            value = r2_ls(p[idx], t[idx])
            if not math.isnan(value):  # a resample of one repeated item has no correlation
                boot.append(value)
    out["r2_ls"] = (r2, 2.0 * float(np.std(boot, ddof=1)) if len(boot) > 1 else math.nan)
    return {name: out[name] for name in METRICS}


# --------------------------------------------------------------------------------------------
# Data set and runs
# --------------------------------------------------------------------------------------------

_IMAGE_COLUMNS = ("image", "image_path", "path", "file")
_MASS_COLUMNS = ("mass_kg", "true_mass_kg", "mass", "true_mass")


@dataclass(frozen=True)
class BenchItem:
    """One row of a benchmark CSV: an image (absolute path), a description and the true mass (kg)."""

    row: int
    image: Path
    description: str
    true_mass_kg: float


@dataclass(frozen=True)
class ItemResult:
    """An item with its estimate, or the error that prevented one."""

    item: BenchItem
    estimate: MassEstimate | None
    error: str | None = None


def load_dataset(csv_path: Path) -> list[BenchItem]:
    """Read a CSV with columns ``image`` (relative to the CSV), ``description`` and ``mass_kg``.

    Accepted aliases: ``image_path``/``path``/``file`` and ``true_mass_kg``/``mass``/``true_mass``.
    Rows are named by their line in the file (the header is line 1) in error messages.
    """
    path = Path(csv_path)
    try:
        if path.stat().st_size > 64 * 2**20:
            raise InvalidInputError(f"dataset {str(path)!r}: larger than 64 MiB; expected a CSV of items")
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InvalidInputError(f"dataset {str(path)!r}: not UTF-8 text (offset {exc.start}); "
                                "save it as UTF-8") from None
    except OSError as exc:
        raise InvalidInputError(f"dataset {str(path)!r}: cannot be read ({exc.strerror or exc})") from exc
    if "\0" in text:
        raise InvalidInputError(f"dataset {str(path)!r}: contains a NUL character (line "
                                f"{text.count(chr(10), 0, text.index(chr(0))) + 1}); expected CSV text")
    reader = csv.DictReader(text.splitlines())
    fields = [f.strip().lower() for f in reader.fieldnames or []]
    image_col = next((c for c in _IMAGE_COLUMNS if c in fields), None)
    mass_col = next((c for c in _MASS_COLUMNS if c in fields), None)
    if image_col is None or mass_col is None or "description" not in fields:
        raise InvalidInputError(
            f"dataset {str(path)!r}: expected columns image, description and mass_kg, got {fields}"
        )
    items: list[BenchItem] = []
    for raw in reader:
        row_no = reader.line_num  # the physical line, so blank lines do not shift the numbers
        if None in raw or None in raw.values():  # more or fewer cells than the header names
            cells = sum(v is not None for k, v in raw.items() if k is not None) + len(raw.get(None) or [])
            raise InvalidInputError(f"dataset {str(path)!r}, row {row_no}: expected {len(fields)} cells "
                                    f"({', '.join(fields)}), got {cells}")
        row = {(k or "").strip().lower(): (v or "").strip() for k, v in raw.items()}
        if not any(row.values()):
            continue
        try:
            mass = float(row[mass_col])
        except ValueError:
            raise InvalidInputError(
                f"dataset {str(path)!r}, row {row_no}: {mass_col} must be a number, got {row[mass_col]!r}"
            ) from None
        if not (math.isfinite(mass) and mass > 0):
            raise InvalidInputError(
                f"dataset {str(path)!r}, row {row_no}: {mass_col} must be > 0, got {mass}"
            )
        if not row[image_col]:
            raise InvalidInputError(f"dataset {str(path)!r}, row {row_no}: {image_col} is empty")
        image = (path.parent / row[image_col]).resolve()
        items.append(BenchItem(row_no, image, row["description"], mass))
    if not items:
        raise InvalidInputError(f"dataset {str(path)!r}: no rows")
    return items


def run_benchmark(
    items: Sequence[BenchItem],
    estimator: MassEstimator,
    workers: int = 4,
    progress: TextIO | None = sys.stderr,
    on_result: Callable[[ItemResult], None] | None = None,
) -> list[ItemResult]:
    """Estimate every item with at most ``workers`` requests in flight, in the items' order.

    A failing item (any :class:`ForteError`, e.g. an invalid VLM answer or a missing image) is
    recorded with its message and the run goes on. Progress lines go to ``progress`` unless None.
    """
    if workers < 1:
        raise InvalidInputError(f"workers: expected >= 1, got {workers}")
    results: list[ItemResult | None] = [None] * len(items)
    lock = threading.Lock()
    done = 0

    def one(item: BenchItem) -> ItemResult:
        if not item.image.is_file():
            return ItemResult(item, None, f"image not found: {item.image}")
        try:
            return ItemResult(item, estimator.estimate(item.description, item.image))
        except ForteError as exc:
            return ItemResult(item, None, str(exc))

    with ThreadPoolExecutor(max_workers=workers) as pool:
        futures = {pool.submit(one, item): i for i, item in enumerate(items)}
        for future in as_completed(futures):
            i = futures[future]
            result = future.result()
            results[i] = result
            with lock:
                done += 1
                if progress is not None:
                    what = (
                        f"{result.estimate.mass_kg:.3g} kg (true {result.item.true_mass_kg:.3g} kg)"
                        if result.estimate
                        else f"FAILED: {result.error}"
                    )
                    print(
                        f"[{done}/{len(items)}] {result.item.image.name}: {what}", file=progress, flush=True
                    )
            if on_result is not None:
                on_result(result)
    return [r for r in results if r is not None]


def summarize_results(results: Sequence[ItemResult], n_boot: int = 1000, seed: int = 0) -> dict[str, Any]:
    """Metrics over the items that got an estimate, the counts of successes and failures, and the
    rows whose description states a mass (``stated_mass_rows``: their answer is in the text)."""
    ok = [r for r in results if r.estimate is not None]
    pred = np.array([r.estimate.mass_kg for r in ok if r.estimate is not None], dtype=float)
    true = np.array([r.item.true_mass_kg for r in ok], dtype=float)
    return {
        "n_items": len(results),
        "n_ok": len(ok),
        "n_failed": len(results) - len(ok),
        "stated_mass_rows": [r.item.row for r in results if states_mass(r.item.description)],
        "metrics": summarize(pred, true, n_boot=n_boot, seed=seed),
    }


def _fmt(value: float, err: float | None = None) -> str:
    if math.isnan(value):
        return "n/a"
    return f"{value:.3f}" if err is None or math.isnan(err) else f"{value:.3f} ± {err:.3f}"


#: Printed under the paper's rows: where they come from and why they cannot be compared.
PAPER_ROWS_NOTE = (
    "These rows come from another data set and another estimator: the paper measured GPT-4o on the "
    "Image2Mass Household test set (56 items / 423 images), and the Image2Mass rows come from the "
    "Image2Mass paper on the same set. They are not comparable with the row above, which was measured "
    "on this data set with this estimator; they are listed for reference only. The Household set's "
    "ground-truth masses are not distributed, so the GPT-4o row cannot be reproduced here."
)


def _table_header() -> list[str]:
    return ["| Method | " + " | ".join(f"{m} {ARROWS[m]}" for m in METRICS) + " |", "|" + "---|" * (len(METRICS) + 1)]


def markdown_table(summary: dict[str, Any], label: str, dataset: str) -> str:
    """The measured row, then the paper's rows in a separate table that says they are not comparable."""
    stated = summary.get("stated_mass_rows") or []
    lines = [
        f"# Mass estimation: {label}",
        "",
        f"Data set: `{dataset}`: {summary['n_ok']} of {summary['n_items']} items estimated, "
        f"{summary['n_failed']} failed. Values ± 2 standard errors (r2_ls: bootstrap over items).",
        "",
    ]
    if stated:
        lines += [
            f"Warning: {len(stated)} of {summary['n_items']} descriptions state a mass (rows "
            f"{', '.join(map(str, stated))}): an estimator that reads the description is given the answer there.",
            "",
        ]
    lines += [*_table_header(), f"| {label} | " + " | ".join(_fmt(*summary["metrics"][m]) for m in METRICS) + " |"]
    lines += ["", "## Reported in the paper (another data set, another estimator: not comparable)", ""]
    lines += _table_header()
    for name, row in PAPER_ROWS.items():
        lines.append(f"| {name} | " + " | ".join(f"{row[m]:.3f}" for m in METRICS) + " |")
    return "\n".join([*lines, "", PAPER_ROWS_NOTE, ""])


PER_ITEM_FIELDS: tuple[str, ...] = (
    "row", "image", "description", "true_mass_kg", "mass_kg", "low_kg", "high_kg", "source", "cached",
    "alde", "ape", "mnre", "within_2x", "error",
)  # fmt: skip


def write_per_item_csv(results: Sequence[ItemResult], path: Path) -> None:
    """One line per item: its estimate and per-item metrics, or its error."""
    with Path(path).open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=PER_ITEM_FIELDS)
        writer.writeheader()
        for r in results:
            line: dict[str, Any] = {
                "row": r.item.row,
                "image": str(r.item.image),
                "description": r.item.description,
                "true_mass_kg": r.item.true_mass_kg,
                "error": r.error or "",
            }
            if r.estimate is not None:
                est, true = r.estimate, r.item.true_mass_kg
                line.update(
                    mass_kg=f"{est.mass_kg:.6g}",
                    low_kg=f"{est.low_kg:.6g}",
                    high_kg=f"{est.high_kg:.6g}",
                    source=est.source,
                    cached=est.cached,
                    alde=f"{alde([est.mass_kg], [true])[0]:.6f}",
                    ape=f"{ape([est.mass_kg], [true])[0]:.6f}",
                    mnre=f"{mnre([est.mass_kg], [true])[0]:.6f}",
                    within_2x=int(within_factor_two([est.mass_kg], [true])[0]),
                )
            writer.writerow(line)
