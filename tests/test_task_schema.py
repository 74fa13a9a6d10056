"""The task file's one description (forte.planning.tasks.task_fields) against its readers, its JSON Schema,
its reference page and the examples (issue 37, item 5)."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

import jsonschema
import pytest
import yaml

from forte.cli.main import main
from forte.exceptions import TaskFileError
from forte.io.task_schema import MARKER, PAGE, json_schema, markdown
from forte.model.robot import default_robot
from forte.planning.tasks.task_fields import FIELDS, MODES, STRICT_VARIANTS, Field
from forte.planning.tasks.tasks import load_task, task_from_dict
from forte.planning.terms.costs import COST_TERMS

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples" / "tasks").glob("*.yaml"))
BOGUS = "zz_not_a_field"
WAYPOINTS = [{"t": 0.0, "position": [0.0, 0.0, 0.0]}, {"t": 1.0, "position": [0.1, 0.0, 0.0]}]
_HOME = default_robot().home().tolist()
TAUGHT = [{"t": 0.0, "q": _HOME}, {"t": 1.0, "q": [_HOME[0] + 0.05, *_HOME[1:]]}]
GOAL = {"kind": "goal", "samples": 5, "configuration": [*_HOME[:3], _HOME[3] + 0.1, *_HOME[4:]]}
POSE_GOAL = {"kind": "goal", "samples": 5, "pose": {"position": [0.8, 0.0, 0.95]}}
VIA_GOAL = {**POSE_GOAL, "samples": 6, "via": [{"position": [0.8, 0.0, 0.95]}]}
PICK = {"kind": "goal", "samples": 6, "goals": [{"pose": {"position": [0.8, 0.0, 0.95]}}] * 2}
#: A valid task every probe starts from (the built-in robot, 5 samples).
BASE: dict[str, Any] = {"path": {"relative": True, "samples": 5, "waypoints": WAYPOINTS}, "payload": {"mass": 1.0}}
HOLD: dict[str, Any] = {"mode": "hold", "pose": {"position": [0.0, 0.0, 0.0], "relative": True},
                        "payload": {"mass": 1.0}}
CONTACT = {"push-box": {"kind": "push-box", "mass": 5.0, "friction": 0.3},
           "drawer": {"kind": "drawer", "mass": 2.0}, "carry": {"kind": "carry", "mass": 2.0,
                                                                 "com": [0, 0, 0.3], "partner": [0, 0, 0.6]}}
SHAPES = {"box": {"size": [0.1, 0.1, 0.1]}, "cylinder": {"radius": 0.1, "length": 0.2}, "sphere": {"radius": 0.1},
          "capsule": {"radius": 0.1, "length": 0.2}, "mesh": {"file": "none.stl"}}

SENSED = {"point_cloud": {"file": "none.ply"},
          "depth_image": {"file": "none.npy", "intrinsics": {"fx": 500, "fy": 500, "cx": 320, "cy": 240}}}


def _with(task: dict[str, Any], where: tuple[Any, ...], value: dict[str, Any]) -> dict[str, Any]:
    """``task`` with the mapping at ``where`` (keys and list indices) replaced by ``value`` plus a bogus field."""
    out = copy.deepcopy(task)
    node: Any = out
    for key in where[:-1]:
        node = node.setdefault(key, {}) if isinstance(key, str) else node[key]
    node[where[-1]] = {**value, BOGUS: 1}
    return out


def _probes() -> dict[str, dict[str, Any]]:
    """A task per mapping of the description (and per strict variant) with a bogus field in it."""
    probes = {
        "": {**BASE, BOGUS: 1},
        "robot": _with(BASE, ("robot",), {"preset": "authors"}),
        "robot.mount": _with(BASE, ("robot", "mount"), {"xyz": [0, 0, 0.5]}),
        "robot.tool": _with(BASE, ("robot", "tool"), {"mass": 1.0}),
        "path|waypoints": _with(BASE, ("path",), BASE["path"]),
        "path|windowed-sine": _with(BASE, ("path",), {"kind": "windowed-sine", "duration": 1.0, "samples": 5,
                                                      "amplitude": [0.01, 0, 0], "frequency": [1, 0, 0]}),
        "path|taught": _with(BASE, ("path",), {"kind": "taught", "samples": 5, "configurations": TAUGHT}),
        "path.waypoints[]": _with(BASE, ("path", "waypoints", 0), WAYPOINTS[0]),
        "path.waypoints[].orientation": _with(BASE, ("path", "waypoints", 1, "orientation"), {"rpy": [0, 0, 0]}),
        "path.keep_level": _with(BASE, ("path", "keep_level"), {"axis": "-z", "max_tilt_deg": 10}),
        "path.orientation": _with(BASE, ("path", "orientation"), {"rpy": [0, 0, 0]}),
        "path|goal": _with(BASE, ("path",), GOAL),
        "path.pose": _with({**BASE, "path": POSE_GOAL}, ("path", "pose"), POSE_GOAL["pose"]),
        "path.pose.orientation": _with({**BASE, "path": POSE_GOAL}, ("path", "pose", "orientation"),
                                       {"rpy": [0, 0, 0]}),
        "path.tolerance": _with({**BASE, "path": POSE_GOAL}, ("path", "tolerance"), {"position": 0.01}),
        "path.via[]": _with({**BASE, "path": VIA_GOAL}, ("path", "via", 0), VIA_GOAL["via"][0]),
        "path.via[].orientation": _with({**BASE, "path": VIA_GOAL}, ("path", "via", 0, "orientation"),
                                        {"rpy": [0, 0, 0]}),
        "path.via[].tolerance": _with({**BASE, "path": VIA_GOAL}, ("path", "via", 0, "tolerance"), {}),
        "path.goals[]": _with({**BASE, "path": PICK}, ("path", "goals", 0), PICK["goals"][0]),
        "path.goals[].pose": _with({**BASE, "path": PICK}, ("path", "goals", 0, "pose"), POSE_GOAL["pose"]),
        "path.goals[].pose.orientation": _with({**BASE, "path": PICK}, ("path", "goals", 0, "pose", "orientation"),
                                               {"rpy": [0, 0, 0]}),
        "path.goals[].tolerance": _with({**BASE, "path": PICK}, ("path", "goals", 0, "tolerance"), {}),
        "path.configurations[]": _with({**BASE, "path": {"kind": "taught", "configurations": [{}, {}]}},
                                       ("path", "configurations", 0), {"t": 0.0}),
        "pose": _with(HOLD, ("pose",), HOLD["pose"]),
        "pose.orientation": _with(HOLD, ("pose", "orientation"), {"rpy": [0, 0, 0]}),
        "payload": _with(BASE, ("payload",), BASE["payload"]),
        "force": _with(BASE, ("force",), {"kind": "constant", "vector": [0, 0, 1.0]}),
        "scene[]": {**BASE, "scene": [{"box": SHAPES["box"], "pose": [5, 5, 0, 0, 0, 0], BOGUS: 1}]},
        "floor": _with(BASE, ("floor",), {"height": 0.0}),
        "weights": _with(BASE, ("weights",), {}),
        "weights.capability_params": _with(BASE, ("weights", "capability_params"), {}),
        "terms": _with(BASE, ("terms",), {}),
        "solver": _with(BASE, ("solver",), {}),
        "limits": _with(BASE, ("limits",), {}),
        "controller": _with(BASE, ("controller",), {}),
    }
    for kind, shape in SHAPES.items():
        probes[f"scene[].{kind}"] = {**BASE, "scene": [{kind: {**shape, BOGUS: 1}, "pose": [5, 5, 0, 0, 0, 0]}]}
    for kind, sensed in SENSED.items():
        probes[f"scene[].{kind}"] = {**BASE, "scene": [{kind: {**sensed, BOGUS: 1}, "pose": [5, 5, 0, 0, 0, 0]}]}
    for kind, sensed in SENSED.items():
        probes[f"scene[].{kind}.merge"] = {**BASE, "scene": [{kind: {**sensed, "merge": {BOGUS: 1}},
                                                               "pose": [5, 5, 0, 0, 0, 0]}]}
    probes["scene[].depth_image.intrinsics"] = {**BASE, "scene": [{"depth_image": {
        **SENSED["depth_image"], "intrinsics": {**SENSED["depth_image"]["intrinsics"], BOGUS: 1}},
        "pose": [5, 5, 0, 0, 0, 0]}]}
    for kind, contact in CONTACT.items():
        probes[f"contact|{kind}"] = _with({k: v for k, v in BASE.items() if k != "payload"}, ("contact",), contact)
    for name in COST_TERMS:
        probes[f"terms.{name}"] = _with(BASE, ("terms", name), {})
    return probes


def _accepted(task: dict[str, Any]) -> tuple[str, set[str]]:
    """Where the reader refuses the bogus field, and the fields it says it expects there."""
    with pytest.raises(TaskFileError) as info:
        task_from_dict(task)
    m = re.fullmatch(r"<task>: (\S+): (?:unknown field|not a registered cost term); expected one of (.+?)"
                     r"(?:; did you mean '.*'\?)?", str(info.value))
    assert m, str(info.value)
    return m[1], set(m[2].split(", "))


def _described(parent: str, variant: str | None = None) -> set[str]:
    children = [f for f in FIELDS if f.parent == parent]
    if parent in STRICT_VARIANTS:
        children = [f for f in children if f.when is None or f.when[1] == variant]
    return {f.name for f in children}


@pytest.mark.parametrize("probe", sorted(_probes()))
def test_each_mapping_accepts_exactly_the_described_fields(probe):
    """The reader's known fields of every mapping (from its own unknown-field error) are the description's."""
    parent, _, variant = probe.partition("|")
    where, accepted = _accepted(_probes()[probe])
    assert re.sub(r"\[\d+\]", "[]", where) == (f"{parent}.{BOGUS}" if parent else BOGUS)
    assert accepted == _described(parent, variant or None), probe


def test_every_described_mapping_is_probed():
    parents = {f.parent for f in FIELDS}
    probed = {p.partition("|")[0] for p in _probes()}
    assert parents == probed
    for strict in STRICT_VARIANTS:  # a probe per variant of a mapping that refuses the others' fields
        assert {f.when[1] for f in FIELDS if f.parent == strict and f.when} == {
            p.partition("|")[2] for p in _probes() if p.startswith(f"{strict}|")}


def test_the_constants_the_description_repeats_agree_with_their_owners():
    from forte.execution.gains import CONTROLLER_FIELDS as GAINS_FIELDS
    from forte.planning.tasks.schema import CONTROLLER_FIELDS, SUPPORT_FIELDS
    from forte.planning.tasks.tasks import MODES as READER_MODES

    assert MODES == READER_MODES
    assert set(CONTROLLER_FIELDS) == set(GAINS_FIELDS) == _described("controller")
    assert set(SUPPORT_FIELDS) <= _described("robot")


SAMPLES = [-1, 0, 0.01, 0.3, 0.5, 0.7, 1, 1.5, 2, 41, 1e6, True, "authors", "box", "range", "auto", "x", None,
           [1.0, 1.0, 0.5], [-1.0, 0.0, 0.0], [1.0] * 10]


@pytest.mark.parametrize("field", [f for f in FIELDS if f.path.startswith("terms.") and f.path.count(".") == 2
                                   and f.name != "weight"], ids=lambda f: f.path)
def test_a_term_setting_schema_accepts_what_the_term_declares(field: Field):
    """For each declared setting, the schema and the setting's own check agree on a range of values."""
    _, term, name = field.path.split(".")
    declared = next(s for s in COST_TERMS[term].settings if s.name == name)
    validator = jsonschema.Draft202012Validator(field.type.schema)
    for value in SAMPLES:
        if declared.kind.startswith("int") and isinstance(value, float) and value.is_integer():
            continue  # JSON Schema counts 1e6 as an integer, the reader does not (the page says so)
        given = tuple(float(v) for v in value) if isinstance(value, list) else value
        if isinstance(value, int) and not isinstance(value, bool) and declared.kind.startswith("float"):
            given = float(value)  # what the reader does (terms_section.read_setting)
        try:
            declared.check(given)
            ok = True
        except ValueError:
            ok = False
        assert validator.is_valid(value) == ok, (field.path, value)


def test_the_reference_page_is_the_description():
    page = (ROOT / PAGE).read_text(encoding="utf-8")
    listed = re.findall(r"^\| `([^`]+)`", page, flags=re.M)
    assert listed == [f.path for f in FIELDS], f"regenerate: forte schema --markdown --out {PAGE}"
    assert page == markdown(), f"regenerate: forte schema --markdown --out {PAGE}"
    nav = yaml.safe_load((ROOT / "mkdocs.yml").read_text())["nav"]
    assert "task-files.md" in json.dumps(nav)


def test_the_schema_is_valid_and_every_example_passes():
    schema = json_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    assert len(EXAMPLES) >= 10
    for path in EXAMPLES:
        task = yaml.safe_load(path.read_text())
        errors = [f"{list(e.absolute_path)}: {e.message}" for e in validator.iter_errors(task)]
        assert not errors, (path.name, errors)


#: Broken task files (a change to a valid one): the schema and the reader refuse each.
BROKEN: dict[str, dict[str, Any]] = {
    "misspelt field": {**BASE, "pathh": BASE["path"]},
    "radius as words": {**BASE, "uncertainty_radius": "ten"},
    "unknown mode": {**BASE, "mode": "hover"},
    "unknown preset": {**BASE, "robot": {"preset": "pr2"}},
    "sine path without duration": {**BASE, "path": {"kind": "windowed-sine", "amplitude": [0, 0, 0.1],
                                                    "frequency": [0, 0, 0.5]}},
    "a sine's amplitude on a waypoint path": {**BASE, "path": {**BASE["path"], "amplitude": [0, 0, 0.1]}},
    "drawer field in a push": {"path": BASE["path"], "contact": {**CONTACT["push-box"], "stiffness": 10.0}},
    "two shapes in one body": {**BASE, "scene": [{"box": SHAPES["box"], "sphere": SHAPES["sphere"],
                                                  "pose": [5, 5, 0, 0, 0, 0]}]},
    "floor in words": {**BASE, "floor": "nope"},
    "negative tip-over margin": {**BASE, "terms": {"tipover": {"margin": -0.1}}},
    "no iterations": {**BASE, "solver": {"max_iter": 0}},
    "clearance of a metre and more": {**BASE, "clearance": 1.5},
    "a 2-vector position": {**BASE, "path": {**BASE["path"], "waypoints": [{"t": 0, "position": [0, 0]},
                                                                             WAYPOINTS[1]]}},
}


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_a_broken_task_is_refused_by_the_schema_and_the_reader(case):
    task = BROKEN[case]
    assert not jsonschema.Draft202012Validator(json_schema()).is_valid(task), case
    with pytest.raises(TaskFileError):
        task_from_dict(task)


def test_the_base_task_passes_both():
    """The probes' and broken cases' starting point is valid: what they change is what is refused."""
    assert jsonschema.Draft202012Validator(json_schema()).is_valid(BASE)
    assert task_from_dict(copy.deepcopy(BASE)).n == 5
    assert load_task(ROOT / "examples" / "tasks" / "lift.yaml").n > 2


def test_forte_schema_prints_a_valid_schema(capsys):
    assert main(["schema"]) == 0
    schema = json.loads(capsys.readouterr().out)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema == json_schema()


def test_forte_schema_out_writes_and_rewrites_its_own_file_only(tmp_path, capsys):
    out = tmp_path / "task.schema.json"
    assert main(["schema", "--out", str(out)]) == 0
    assert json.loads(out.read_text()) == json_schema()
    assert main(["schema", "--out", str(out)]) == 0  # its own file: rewritten
    page = tmp_path / "page.md"
    assert main(["schema", "--markdown", "--out", str(page)]) == 0 and page.read_text() == markdown()
    capsys.readouterr()
    foreign = tmp_path / "mine.json"
    foreign.write_text('{"mine": true}\n')
    for bad in (foreign, tmp_path, tmp_path / "missing" / "x.json"):
        assert main(["schema", "--out", str(bad)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("forte: error: --out "), err
    assert foreign.read_text() == '{"mine": true}\n'
    assert MARKER in out.read_text()
