"""Mass estimates: the offline table, the user override, answer validation, images, the radius."""

from __future__ import annotations

import base64
import json
import math
from pathlib import Path

import numpy as np
import pytest

from forte.cli.main import main
from forte.exceptions import EstimationError, InvalidInputError
from forte.force.estimate import MassEstimate, MassEstimator, estimate_payload, radius_from_estimate
from forte.force.images import data_url, image_bytes
from forte.force.offline import OfflineEstimator
from forte.force.quantities import parse_quantities, states_mass
from forte.force.vlm import VLMConfig
from forte.force.vlm_answer import parse_answer
from forte.force.vlm_cache import cache_key, server_id, write_entry

IMAGE = Path(__file__).resolve().parents[1] / "examples" / "massbench" / "images" / "dumbbell.png"

# description, expected mass (kg), hand-computed from the documented table
OFFLINE_CASES = [
    ("Carry the 2.7 L beverage in the basket", 2.7 * 1.02 * 1.03),
    ("Hand over a 330 mL can of cola", 0.33 * 1.04 * 1.045),
    ("a 0.33 L can of soda", 0.33 * 1.04 * 1.045),
    ("Bring 500 g of flour", 0.5),
    ("Lift a 2 kg dumbbell", 2.0),
    ("1.5 kg", 1.5),
    ("two 1.5 L bottles of water", 2 * 1.5 * 1.0 * 1.025),
    ("3 x 330ml cans of beer", 3 * 0.33 * 1.01 * 1.045),
    ("a six-pack of 0.5 L water bottles", 6 * 0.5 * 1.0 * 1.025),
    ("a 750 mL glass bottle of wine", 0.75 * 0.99 * 1.6),
    ("a 1 gallon jug of milk", 3.785411784 * 1.03 * 1.05),
    ("a 2.5 lb bag of sugar", 2.5 * 0.45359237),
    ("16 oz of ground coffee", 16 * 0.028349523125),
    ("a 2 kg dumbbell and a 500 g book", 2.5),
    ("a 1.5-litre bottle of olive oil", 1.5 * 0.92 * 1.025),
]


@pytest.mark.parametrize(("description", "mass"), OFFLINE_CASES)
def test_offline_table(description: str, mass: float) -> None:
    est = OfflineEstimator().estimate(description, None)
    assert est.mass_kg == pytest.approx(mass, rel=1e-9)
    assert est.low_kg < est.mass_kg < est.high_kg
    assert est.source == "offline:quantity-table-v2"  # v2: object classes added
    assert est.rationale
    assert est.objects and sum(o.mass_kg for o in est.objects) == pytest.approx(est.mass_kg)


def test_offline_intervals() -> None:
    dumbbell = OfflineEstimator().estimate("a 2 kg dumbbell", None)
    assert (dumbbell.low_kg, dumbbell.high_kg) == pytest.approx((1.9, 2.1))  # +-5 % on a stated mass
    hedged = OfflineEstimator().estimate("about 2 kg of apples", None)
    assert (hedged.low_kg, hedged.high_kg) == pytest.approx((1.6, 2.4))  # +-20 % when hedged
    water = OfflineEstimator().estimate("two 1.5 L bottles of water", None)
    assert water.low_kg == pytest.approx(3.0 * 0.997 * 1.015)
    assert water.high_kg == pytest.approx(3.0 * 1.003 * 1.05)
    unknown = OfflineEstimator().estimate("a 2 L box", None)  # contents not named: wide interval
    assert unknown.low_kg == pytest.approx(2 * 0.5) and unknown.high_kg == pytest.approx(2 * 1.5 * 1.1)


def test_offline_unnamed_bottle_contents_taken_as_beverage() -> None:
    (q,) = parse_quantities("two 1.5 L bottles")
    assert q.count == 2 and q.mass_kg == pytest.approx(3 * 1.02 * 1.025)


@pytest.mark.parametrize(
    "description", ["Carry the red bottle to the table", "a heavy box", "move it 2 m to the left", "", "   "]
)
def test_offline_refuses_without_a_quantity(description: str) -> None:
    with pytest.raises(EstimationError, match="--mass"):
        OfflineEstimator().estimate(description, None)


# description, expected mass (kg) from the typical masses of ITEM_CLASSES
OBJECT_CASES = [
    ("Carry the four apples.", 4 * 0.18),
    ("Lift the dumbbell from the rack.", 5.0),
    ("Bring the bag of rice to the table.", 1.0),
    ("a dozen eggs", 12 * 0.06),
    ("3 red apples and two 1.5 L bottles of water", 3 * 0.18 + 2 * 1.5 * 1.0 * 1.025),
    ("a 500 g book and a laptop", 0.5 + 1.8),  # the stated book is not counted twice
]


@pytest.mark.parametrize(("description", "mass"), OBJECT_CASES)
def test_offline_object_classes(description: str, mass: float) -> None:
    est = OfflineEstimator().estimate(description, None)
    assert est.mass_kg == pytest.approx(mass, rel=1e-9)
    assert est.low_kg < est.mass_kg < est.high_kg


def test_offline_plural_without_a_count_is_not_guessed() -> None:
    with pytest.raises(EstimationError, match="no mass or volume stated, and no known object named"):
        OfflineEstimator().estimate("carry apples", None)


def test_offline_can_ignore_stated_masses() -> None:
    honest = OfflineEstimator(stated_masses=False)
    assert honest.estimate("Lift a 2 kg dumbbell", None).mass_kg == 5.0  # the class, not the stated 2 kg
    assert honest.estimate("two 1.5 L bottles", None).mass_kg == pytest.approx(3 * 1.02 * 1.025)
    with pytest.raises(EstimationError, match=r"looked for mL, L"):
        honest.estimate("Bring 500 g of flour", None)
    assert states_mass("Bring 500 g of flour") and states_mass("a 2.5 lb bag") and states_mass("1 KG")
    assert not states_mass("two 1.5 L bottles") and not states_mass("move it 2 m to the left")


def test_offline_refuses_implausible_total() -> None:
    with pytest.raises(EstimationError, match="outside the plausible payload range"):
        OfflineEstimator().estimate("a 900 kg crate", None)


def test_estimators_follow_the_protocol() -> None:
    assert isinstance(OfflineEstimator(), MassEstimator)


def test_user_mass_always_wins(tmp_path: Path) -> None:
    vlm = VLMConfig(base_url="http://127.0.0.1:9/v1", api_key_env="FORTE_NO_SUCH_VAR")
    est = estimate_payload("two 1.5 L bottles", IMAGE, mass=4.2, vlm=vlm, cache_dir=tmp_path)
    assert (est.mass_kg, est.low_kg, est.high_kg, est.source) == (4.2, 4.2, 4.2, "user")
    assert not list(tmp_path.iterdir())  # no request, no cache
    with pytest.raises(InvalidInputError, match="mass"):
        estimate_payload("x", None, mass=-1.0)


def test_estimate_payload_defaults_to_offline() -> None:
    est = estimate_payload("a 2 kg dumbbell", IMAGE)
    assert est.source.startswith("offline") and est.mass_kg == 2.0


def test_mass_estimate_validation_and_dict() -> None:
    est = MassEstimate(2.0, 1.5, 2.5, "test", "why")
    assert est.to_dict() == {
        "mass_kg": 2.0, "low_kg": 1.5, "high_kg": 2.5, "source": "test", "rationale": "why", "cached": False,
        "objects": [],
    }  # fmt: skip
    assert MassEstimate.from_dict(est.to_dict()) == est
    assert est.half_width_kg == 0.5
    json.dumps(est.to_dict())
    with pytest.raises(EstimationError, match="low_kg <= mass_kg <= high_kg"):
        MassEstimate(3.0, 1.5, 2.5, "test")
    with pytest.raises(EstimationError, match="mass_kg: expected a finite number"):
        MassEstimate(math.nan, 1.5, 2.5, "test")
    with pytest.raises(EstimationError, match="low_kg: expected a positive mass"):
        MassEstimate(1.0, 0.0, 2.5, "test")


def test_radius_from_estimate_hand_computed() -> None:
    est = MassEstimate(3.0, 2.0, 4.0, "test")  # half width 1 kg
    acc = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 10.0], [3.0, 4.0, -9.81], [0.0, 0.0, -9.81]])
    r = radius_from_estimate(acc, est, r_min=5.0)
    # |a - g| = 9.81, 19.81, 5, 0 -> times 1 kg, floored at 5 N
    np.testing.assert_allclose(r, [9.81, 19.81, 5.0, 5.0])
    np.testing.assert_allclose(radius_from_estimate(acc, est), [10.0, 19.81, 10.0, 10.0])  # paper's 10 N
    user = MassEstimate(3.0, 3.0, 3.0, "user")
    np.testing.assert_allclose(radius_from_estimate(acc, user), 10.0)
    with pytest.raises(InvalidInputError, match="acc"):
        radius_from_estimate(np.zeros((4, 2)), est)
    with pytest.raises(InvalidInputError, match="r_min"):
        radius_from_estimate(acc, est, r_min=-1.0)


def test_image_bytes(tmp_path: Path) -> None:
    data, mime = image_bytes(IMAGE)
    assert mime == "image/png" and data == IMAGE.read_bytes()
    jpeg = tmp_path / "photo.bin"
    jpeg.write_bytes(b"\xff\xd8\xff\xe0fake-jpeg")
    assert image_bytes(jpeg) == (b"\xff\xd8\xff\xe0fake-jpeg", "image/jpeg")  # sent as they are
    assert image_bytes(str(tmp_path / "photo.bin"))[1] == "image/jpeg"
    grey, _ = image_bytes(np.linspace(0, 1, 12).reshape(3, 4))
    assert grey.startswith(b"\x89PNG")
    url = data_url(b"abc", "image/png")
    assert url == "data:image/png;base64," + base64.b64encode(b"abc").decode()
    with pytest.raises(InvalidInputError, match="cannot be read"):
        image_bytes(tmp_path / "missing.png")
    bad = tmp_path / "notes.txt"
    bad.write_text("hello")
    with pytest.raises(InvalidInputError, match="expected a PNG, JPEG"):
        image_bytes(bad)
    with pytest.raises(InvalidInputError, match="H x W"):
        image_bytes(np.zeros((2, 2, 5)))
    with pytest.raises(InvalidInputError, match=r"\[0, 1\]"):
        image_bytes(np.full((2, 2), 3.0))


def test_parse_answer() -> None:
    good = {"object": "can", "mass_kg": 0.35, "low_kg": 0.3, "high_kg": 0.4, "rationale": "330 mL"}
    est = parse_answer(json.dumps(good), "vlm:m")
    assert (est.mass_kg, est.source, est.rationale) == (0.35, "vlm:m", "can: 330 mL")
    fenced = parse_answer("```json\n" + json.dumps(good) + "\n```", "vlm:m")
    assert fenced.mass_kg == 0.35
    for content, message in [
        ("", "empty content"),
        ("{", "not valid JSON"),
        (json.dumps({**good, "mass_kg": math.inf}), "not valid JSON|finite"),
        (json.dumps({**good, "mass_kg": True}), "must be a number"),
        (json.dumps({**good, "low_kg": 0.0005}), "outside the plausible payload range"),
        (json.dumps({**good, "high_kg": 600.0}), "outside the plausible payload range"),
    ]:
        with pytest.raises(EstimationError, match=message):
            parse_answer(content, "vlm:m")


def test_cache_key_depends_on_every_input() -> None:
    request = {
        "server": "http://127.0.0.1:8000/v1", "model": "gpt-4o", "prompt_version": "v", "system_prompt": "p",
        "description": "desc", "image_sha256": "a" * 64, "options": {"temperature": 0.0, "max_tokens": 300},
    }  # fmt: skip
    base = cache_key(request)
    assert base == cache_key(dict(reversed(list(request.items()))))  # key order does not matter
    changed = [
        {"server": "http://127.0.0.1:8001/v1"}, {"model": "llava"}, {"prompt_version": "w"},
        {"system_prompt": "q"}, {"description": "other"}, {"image_sha256": "b" * 64},
        {"options": {"temperature": 0.5, "max_tokens": 300}}, {"options": {"temperature": 0.0, "max_tokens": 301}},
    ]  # fmt: skip
    keys = {cache_key({**request, **change}) for change in changed}
    assert len(keys) == len(changed) and base not in keys


def test_server_id_normalizes_and_drops_credentials() -> None:
    assert server_id("HTTPS://API.OpenAI.com/v1/") == "https://api.openai.com/v1"
    assert server_id("http://user:secret@127.0.0.1:8000/v1") == "http://127.0.0.1:8000/v1"
    assert server_id("http://127.0.0.1:8000/v1") != server_id("http://127.0.0.1:8001/v1")


def test_cache_write_is_atomic_and_cleans_up(tmp_path: Path) -> None:
    write_entry(tmp_path, "k", {"estimate": {"mass_kg": 1.0}})
    assert json.loads((tmp_path / "k.json").read_text()) == {"estimate": {"mass_kg": 1.0}}
    (tmp_path / "d.json").mkdir()  # the rename onto a folder fails: logged, no temp file left
    (tmp_path / "d.json" / "x").write_text("")
    write_entry(tmp_path, "d", {"estimate": {}})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.json", "k.json"]


def test_vlm_config_validation() -> None:
    with pytest.raises(InvalidInputError, match="base_url"):
        VLMConfig(base_url="localhost:11434")
    with pytest.raises(InvalidInputError, match="timeout_s"):
        VLMConfig(timeout_s=0)
    with pytest.raises(InvalidInputError, match="max_retries"):
        VLMConfig(max_retries=-1)
    with pytest.raises(InvalidInputError, match="max_tokens"):
        VLMConfig(max_tokens=0)
    with pytest.raises(InvalidInputError, match="temperature"):
        VLMConfig(temperature=-0.1)
    assert VLMConfig().request_options()["temperature"] == 0.0  # the authors' setting
    cfg = VLMConfig(backoff_base_s=0.5, backoff_max_s=3.0)
    assert [cfg.backoff(k) for k in range(4)] == [0.5, 1.0, 2.0, 3.0]


def test_cli_estimate_mass_offline(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["estimate-mass", "--image", str(IMAGE), "--description", "Lift a 2 kg dumbbell"])
    out, _ = capsys.readouterr()
    assert code == 0
    result = json.loads(out)
    assert result["mass_kg"] == 2.0 and result["source"].startswith("offline")
    assert result["radius_at_rest_n"] == 10.0  # 9.81 x 0.1 kg is below the 10 N floor

    code = main(["estimate-mass", "--description", "about 20 kg", "--r-min", "1"])
    result = json.loads(capsys.readouterr().out)
    assert code == 0 and result["radius_at_rest_n"] == pytest.approx(9.81 * 4.0)


def test_cli_estimate_mass_user_mass(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["estimate-mass", "--description", "a heavy box", "--mass", "7.5"])
    result = json.loads(capsys.readouterr().out)
    assert code == 0 and result["source"] == "user" and result["mass_kg"] == 7.5


def test_cli_estimate_mass_refusal(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["estimate-mass", "--image", str(IMAGE), "--description", "a heavy box"])
    _, err = capsys.readouterr()
    assert code == 2
    assert err.startswith("forte: error: no mass or volume stated") and "--mass" in err
    assert main(["estimate-mass"]) == 2
    assert "give --image, --description" in capsys.readouterr().err


def test_an_estimate_that_fails_names_the_file_and_field(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A payload the offline estimator cannot use: one line naming the task file's field, or the
    image given to estimate-mass, exit 2."""
    task = tmp_path / "desc.yaml"
    task.write_text("name: desc\nmode: hold\npose: {position: [0, 0, 0], relative: true}\n"
                    "payload: {description: a thing of unknown kind}\n")
    assert main(["plan", str(task), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"forte: error: {task}: payload.description: no mass or volume stated")
    assert err.count("\n") == 1 and "Traceback" not in err
    task.write_text(f"name: img\nmode: hold\npose: {{position: [0, 0, 0], relative: true}}\n"
                    f"payload: {{image: {IMAGE}}}\n")
    assert main(["plan", str(task), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"forte: error: {task}: payload.image ({IMAGE}): the offline estimator reads no image")
    assert main(["estimate-mass", "--image", str(IMAGE)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"forte: error: --image {IMAGE}: the offline estimator reads no image; it needs a task")
    assert err.count("\n") == 1
