"""Image2Mass metrics on hand-computed cases, the data set loader, the runner and ``bench-mass``."""

from __future__ import annotations

import csv
import importlib.util
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from forte.cli.main import main
from forte.exceptions import EstimationError, InvalidInputError
from forte.force.estimate import MassEstimate
from forte.force.images import ImageInput
from forte.force.massbench import (
    PAPER_ROWS,
    BenchItem,
    alde,
    ape,
    load_dataset,
    markdown_table,
    mnre,
    r2_ls,
    run_benchmark,
    summarize,
    summarize_results,
    within_factor_two,
)
from forte.force.quantities import states_mass

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "massbench"
LN2 = math.log(2.0)


def test_per_item_metrics_hand_computed() -> None:
    pred, true = [2.0, 1.0, 4.0, 0.5], [1.0, 1.0, 1.0, 1.0]
    np.testing.assert_allclose(alde(pred, true), [LN2, 0.0, 2 * LN2, LN2])
    np.testing.assert_allclose(ape(pred, true), [1.0, 0.0, 3.0, 0.5])
    np.testing.assert_allclose(mnre(pred, true), [0.5, 1.0, 0.25, 0.5])
    # a factor of exactly two is not "within a factor of two" (strict <)
    np.testing.assert_array_equal(within_factor_two(pred, true), [0.0, 1.0, 0.0, 0.0])
    np.testing.assert_array_equal(within_factor_two([1.9, 0.6], [1.0, 1.0]), [1.0, 1.0])


def test_r2_ls_hand_computed() -> None:
    true = [1.0, 2.0, 4.0]
    assert r2_ls([2.0, 4.0, 8.0], true) == pytest.approx(1.0)  # a constant factor off: r = 1
    assert r2_ls([8.0, 4.0, 2.0], true) == pytest.approx(1.0)  # r = -1, squared
    # ln m = (0, 1, 2) ln2, ln m_hat = (0, 2, 1) ln2: centred (-1, 0, 1) . (-1, 1, 0) = 1, norms 2 -> r = 0.5
    assert r2_ls([1.0, 4.0, 2.0], true) == pytest.approx(0.25)
    assert math.isnan(r2_ls([1.0, 2.0], [3.0, 3.0]))  # constant truth: undefined
    assert math.isnan(r2_ls([1.0], [1.0]))


def test_summarize_means_and_standard_errors() -> None:
    pred, true = [2.0, 1.0, 4.0], [1.0, 1.0, 1.0]
    s = summarize(pred, true)
    # ALDE = (a, 0, 2a) with a = ln 2: mean a, sample sd a, 2 SE = 2 a / sqrt(3)
    assert s["mALDE"] == pytest.approx((LN2, 2 * LN2 / math.sqrt(3)))
    # APE = (1, 0, 3): mean 4/3, sd sqrt(((1/3)^2 + (4/3)^2 + (5/3)^2) / 2) = sqrt(7/3)
    assert s["mAPE"] == pytest.approx((4 / 3, 2 * math.sqrt(7 / 3) / math.sqrt(3)))
    # MnRE = (0.5, 1, 0.25): mean 7/12
    assert s["mMnRE"][0] == pytest.approx(7 / 12)
    # q = (0, 1, 0): mean 1/3, sd sqrt(1/3), 2 SE = 2/3
    assert s["q"] == pytest.approx((1 / 3, 2 / 3))
    assert math.isnan(s["r2_ls"][0])  # constant truth
    assert list(s) == ["mALDE", "mAPE", "r2_ls", "mMnRE", "q"]


def test_r2_bootstrap_is_seeded_and_sane() -> None:
    rng = np.random.default_rng(1)
    true = np.exp(rng.normal(0, 1, 40))
    pred = true * np.exp(rng.normal(0, 0.3, 40))
    a, b = summarize(pred, true, seed=3), summarize(pred, true, seed=3)
    assert a == b
    value, err = a["r2_ls"]
    assert 0.7 < value < 1.0 and 0.0 < err < 0.2
    perfect = summarize(true * 1.5, true)
    assert perfect["r2_ls"] == pytest.approx((1.0, 0.0), abs=1e-12)
    assert perfect["q"] == (1.0, 0.0)


def test_metric_input_validation() -> None:
    with pytest.raises(InvalidInputError, match="one length"):
        alde([1.0, 2.0], [1.0])
    with pytest.raises(InvalidInputError, match="positive"):
        ape([0.0], [1.0])
    empty = summarize([], [])
    assert all(math.isnan(v) for pair in empty.values() for v in pair)


def test_load_dataset(tmp_path: Path) -> None:
    items = load_dataset(EXAMPLE / "dataset.csv")
    assert len(items) == 8
    assert all(item.image.is_file() for item in items)
    assert items[0].row == 2 and items[0].true_mass_kg == pytest.approx(3.07)
    bad = tmp_path / "bad.csv"
    bad.write_text("image,description\nx.png,y\n")
    with pytest.raises(InvalidInputError, match="expected columns image, description and mass_kg"):
        load_dataset(bad)
    bad.write_text("image,description,mass_kg\nx.png,y,heavy\n")
    with pytest.raises(InvalidInputError, match="row 2: mass_kg must be a number"):
        load_dataset(bad)
    bad.write_text("path,description,true_mass_kg\nx.png,y,1\n\nz.png,w,-1\n")
    with pytest.raises(InvalidInputError, match="row 4: true_mass_kg must be > 0"):
        load_dataset(bad)
    with pytest.raises(InvalidInputError, match="cannot be read"):
        load_dataset(tmp_path / "none.csv")


class Scripted:
    """An estimator that returns twice the true mass, or fails on descriptions containing 'fail'."""

    name = "scripted"

    def estimate(self, description: str | None, image: ImageInput | None) -> MassEstimate:
        if description and "fail" in description:
            raise EstimationError("scripted failure")
        return MassEstimate(2.0, 1.0, 3.0, "scripted")


def test_run_benchmark_counts_failures_and_keeps_order(tmp_path: Path) -> None:
    img = EXAMPLE / "images" / "cola_can.png"
    items = [
        BenchItem(2, img, "ok", 1.0),
        BenchItem(3, img, "please fail", 1.0),
        BenchItem(4, tmp_path / "missing.png", "ok", 1.0),
        BenchItem(5, img, "ok", 4.0),
    ]
    results = run_benchmark(items, Scripted(), workers=3, progress=None)
    assert [r.item.row for r in results] == [2, 3, 4, 5]
    assert results[1].error == "scripted failure" and "image not found" in (results[2].error or "")
    summary = summarize_results(results)
    assert (summary["n_items"], summary["n_ok"], summary["n_failed"]) == (4, 2, 2)
    assert summary["metrics"]["mAPE"][0] == pytest.approx((1.0 + 0.5) / 2)
    table = markdown_table(summary, "scripted", "x.csv")
    for name, row in PAPER_ROWS.items():
        assert name in table and f"{row['mALDE']:.3f}" in table
    assert "2 of 4 items estimated, 2 failed" in table
    with pytest.raises(InvalidInputError, match="workers"):
        run_benchmark(items, Scripted(), workers=0)


def test_cli_bench_mass_offline_on_example(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    code = main(["bench-mass", str(EXAMPLE / "dataset.csv"), "--out", str(out), "--workers", "2"])
    stdout, stderr = capsys.readouterr()
    assert code == 0
    assert "8/8 estimated, 0 failed" in stdout and "[8/8]" in stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_ok"] == 8
    assert summary["estimator"] == "offline (quantity-table-v2, stated masses ignored)"
    assert summary["stated_mass_rows"] == []
    m = summary["metrics"]
    assert m["q"][0] == 7 / 8  # the dumbbell's typical 5 kg is 2.5 times its true 2 kg
    table = (out / "results.md").read_text()
    assert "Image2Mass (multi-view) | 0.437 | 0.637 | 0.701 | 0.693 | 0.786" in table
    assert "not distributed" in table and "not comparable" in stdout
    with (out / "items.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 8 and all(r["error"] == "" for r in rows)
    # the dumbbell's description names the object only: its estimate is the class's typical mass
    assert rows[2]["description"] == "Lift the dumbbell from the rack." and float(rows[2]["mass_kg"]) == 5.0


def test_cli_bench_mass_reports_failures(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "data.csv"
    image = (EXAMPLE / "images" / "dumbbell.png").as_posix()
    data.write_text(
        f"image,description,mass_kg\n{image},a 2 kg dumbbell,2\n{image},a heavy box,2\nnone.png,a 1 kg box,1\n"
    )
    code = main(["bench-mass", str(data), "--out", str(tmp_path / "o"), "--quiet"])
    stdout, stderr = capsys.readouterr()
    assert code == 1 and stderr == ""
    assert "1/3 estimated, 2 failed" in stdout
    with (tmp_path / "o" / "items.csv").open() as fh:
        errors = [r["error"] for r in csv.DictReader(fh)]
    assert errors[0] == "" and "no mass or volume stated" in errors[1] and "image not found" in errors[2]
    with (tmp_path / "o" / "items.csv").open() as fh:
        assert float(next(csv.DictReader(fh))["mass_kg"]) == 5.0  # the stated 2 kg was not read
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["stated_mass_rows"] == [2, 4]
    table = (tmp_path / "o" / "results.md").read_text()
    assert "Warning: 2 of 3 descriptions state a mass (rows 2, 4)" in table
    assert main(["bench-mass", str(tmp_path / "nope.csv"), "--out", str(tmp_path / "o")]) == 2
    assert main(["bench-mass", str(data), "--workers", "0"]) == 2


# any number followed by a mass unit, written independently of forte's own unit table
MASS_IN_TEXT = re.compile(r"\d\s*(mg|g|gr|grams?|kg|kgs|kilos?|kilograms?|lbs?|pounds?|oz|ounces?)\b", re.IGNORECASE)


def test_shipped_descriptions_do_not_state_the_mass() -> None:
    items = load_dataset(EXAMPLE / "dataset.csv")
    for item in items:
        assert not MASS_IN_TEXT.search(item.description), item.description
        assert not states_mass(item.description), item.description
    # the generator writes the same descriptions
    spec = importlib.util.spec_from_file_location("make_dataset", EXAMPLE / "make_dataset.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert [(f"images/{name}", desc, mass) for name, _, desc, mass in module.ITEMS] == [
        (f"images/{item.image.name}", item.description, item.true_mass_kg) for item in items
    ]


def test_table_says_the_paper_rows_are_not_comparable() -> None:
    results = run_benchmark([BenchItem(2, EXAMPLE / "images" / "cola_can.png", "ok", 1.0)], Scripted(), progress=None)
    table = markdown_table(summarize_results(results), "ours", "x.csv")
    assert "another data set" in table and "another estimator" in table and "not comparable" in table
    assert "Image2Mass Household test set (56 items / 423 images)" in table and "GPT-4o" in table
    assert "**" not in table  # nothing in bold, our row least of all
    ours = table.index("| ours |")
    assert all(table.index(f"| {name} |") > table.index("Reported in the paper") > ours for name in PAPER_ROWS)
