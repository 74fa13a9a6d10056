"""Fuzz the command line with generated bad inputs and assert the contract (issue 12).

Families: task files (structured mutations of the examples and byte-level damage), CLI
arguments, tampered plan directories, and benchmark CSVs. Every case runs the CLI in-process
(``forte.cli.main.main``) and asserts: the exit code is 0, 1 or 2 (never 3, never an exception),
no traceback on stderr, and an exit 2 prints exactly one ``forte: error:`` line.

``pytest -q`` runs a fast sample (:data:`FAST` cases per family); ``pytest -m fuzz`` runs the
full one (:data:`FULL` per family, >= 1000 in all). Every case is counted in ``CASES``.
"""

from __future__ import annotations

import collections
import contextlib
import io
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from forte.cli.main import main

REPO = Path(__file__).resolve().parents[1]
TASKS = REPO / "examples" / "tasks"
IMAGES = REPO / "examples" / "massbench" / "images"
FAST, FULL = 12, 300
CASES: collections.Counter[str] = collections.Counter()


def run_cli(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except BaseException as exc:  # the contract: main never raises
            raise AssertionError(f"main({argv!r}) raised {type(exc).__name__}: {exc}") from exc
    return code, err.getvalue()


def assert_contract(argv: list[str], family: str) -> int:
    code, err = run_cli(argv)
    CASES[family] += 1
    context = f"argv={argv!r}\nexit={code}\nstderr={err!r}"
    assert code in (0, 1, 2), context
    assert "Traceback" not in err and "internal error" not in err, context
    errors = [line for line in err.splitlines() if line.startswith("forte: error:")]
    if code == 2:
        assert len(errors) == 1, context
        assert all(line.startswith(("forte:", "usage:")) for line in err.splitlines()), context
    if code == 0:
        assert not errors, context
    return code


def fuzz_settings(n: int):
    return settings(max_examples=n, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))


# -- values -----------------------------------------------------------------------------------
scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-10**30, 10**30), st.sampled_from([0, -1, 1, 2, 10**6, 10**400]),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([1e308, -1e308, 1e-320, float("nan")]),
    st.text(max_size=12), st.sampled_from(["", "1.5", "kg", "trajectory", "hold", "waypoints", "windowed-sine",
                                           "\x00", "caf\u00e9", "erd:nope.urdf", "/etc/passwd", "panda_hand_tcp"]),
)
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=12),
                                                       st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                      max_leaves=24)


def _paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, (*prefix, i))


@st.composite
def mutated_task(draw):
    name = draw(st.sampled_from(["hold", "lift", "continuous"]))
    data = yaml.safe_load((TASKS / f"{name}.yaml").read_text())
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(data) if p]
        where = draw(st.sampled_from(paths))
        parent = data
        for key in where[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
        if action == "delete" and isinstance(parent, dict):
            del parent[where[-1]]
        elif action == "add" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["robot", "path", "force", "tool", "samples", "rate", "solver", "x",
                                         "require_capacity", "limits", "weights", "inertia", "duration"]))] = \
                draw(values)
        else:
            parent[where[-1]] = draw(values)
    return name, data


@st.composite
def damaged_text(draw):
    name = draw(st.sampled_from(["hold", "lift"]))
    raw = (TASKS / f"{name}.yaml").read_bytes()
    kind = draw(st.sampled_from(["truncate", "flip", "insert", "encode", "nest", "yaml-junk"]))
    if kind == "truncate":
        raw = raw[: draw(st.integers(0, len(raw)))]
    elif kind == "flip":
        i = draw(st.integers(0, len(raw) - 1))
        raw = raw[:i] + bytes([draw(st.integers(0, 255))]) + raw[i + 1:]
    elif kind == "insert":
        i = draw(st.integers(0, len(raw)))
        raw = raw[:i] + draw(st.binary(min_size=1, max_size=8)) + raw[i:]
    elif kind == "encode":
        raw = raw.decode().replace("name: hold", "name: caf\u00e9").encode(draw(st.sampled_from(
            ["latin-1", "utf-16", "utf-32", "cp1252"])))
    elif kind == "nest":
        depth = draw(st.integers(50, 20000))
        raw = b"a: " + draw(st.sampled_from([b"[", b"{x: "])) * depth + b"\n"
    else:
        raw = draw(st.sampled_from([b"- a\nb: c", b"{", b"!!python/object:os.system {}", b"a: &x [*x]",
                                    b"key: value\n  bad: indent", b"\t- x", b"--- !!binary x\n", b"\xef\xbb\xbf"]))
    return name, raw


def _plan_args(name: str, out: Path) -> list[str]:
    method = {"hold": "teaching", "lift": "quintic", "continuous": "quintic"}[name]
    extra = ["--waypoints", "6"] if name != "hold" else []
    return ["plan", "", "--method", method, "--no-figures", "--quiet", "--out", str(out), *extra]


def _task_case(name: str, content: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "task.yaml"
        path.write_bytes(content)
        argv = _plan_args(name, Path(tmp) / "out")
        argv[1] = str(path)
        assert_contract(argv, "task files")


def _dump(data) -> bytes:
    try:
        return yaml.safe_dump(data, allow_unicode=True).encode()
    except (yaml.YAMLError, ValueError, OverflowError):
        return repr(data).encode()


# -- CLI arguments ------------------------------------------------------------------------------
numbers = st.one_of(st.sampled_from(["-5", "0", "1e308", "nan", "inf", "-inf", "", "abc", "1e-320", "True",
                                     "100000000", "-1", "2.5", "0x10", "1_000"]), st.integers(-10**6, 10**9).map(str))


@st.composite
def argvs(draw):
    tmp = "TMP"
    cmd = draw(st.sampled_from(["plan", "compare", "simulate", "estimate-mass", "bench-mass", "demo", "experiment",
                                "nosuch", "--version", "-h"]))
    argv = [cmd]
    if cmd in ("plan", "compare"):
        argv.append(draw(st.sampled_from([str(TASKS / "hold.yaml"), f"{tmp}/missing.yaml", tmp, "", "-"])))
        argv += ["--no-figures", "--quiet", "--method", "teaching"] if cmd == "plan" else ["--no-figures", "--quiet"]
        if cmd == "compare":  # keep it fast: compare only ever sees a bad value below
            argv += ["--waypoints", draw(st.sampled_from(["0", "-3", "abc", "100000000"]))]
    elif cmd == "simulate":
        argv.append(draw(st.sampled_from([f"{tmp}/none", tmp, str(TASKS / "hold.yaml"), ""])))
    elif cmd == "bench-mass":
        argv += [draw(st.sampled_from([f"{tmp}/none.csv", str(REPO / "examples/massbench/dataset.csv")])), "--quiet"]
    elif cmd == "experiment":
        argv += [draw(st.sampled_from(["lift", "hold", "nope", ""])),
                 draw(st.sampled_from(["--trials", "--waypoints"])), draw(st.sampled_from(["-1", "1000000", "1"]))]
        argv += ["--out", f"{tmp}/afile"]  # a plain file: refused before any work
    options = {
        "plan": ["--mass", "--waypoints", "--out", "--model", "--bogus", "--require-capacity"],
        "compare": ["--mass", "--out"],
        "simulate": ["--mass", "--hold", "--out", "--frames", "--video", "--sag", "--bandwidth", "--gains"],
        "estimate-mass": ["--image", "--description", "--mass", "--r-min", "--timeout", "--retries"],
        "bench-mass": ["--bootstrap", "--workers", "--out", "--retries", "--timeout"],
        "demo": ["--mass", "--radius", "--json"],
    }.get(cmd, [])
    for _ in range(draw(st.integers(0, 3)) if options else 0):
        flag = draw(st.sampled_from(options))
        argv.append(flag)
        if flag in ("--out", "--frames", "--video", "--image", "--gains"):
            argv.append(draw(st.sampled_from([f"{tmp}/afile", f"{tmp}/new", f"{tmp}/afile/sub", "", ".",
                                              "/proc/forte", f"{tmp}/dir", str(IMAGES / "wine.png"), "x.mp4"])))
        elif flag == "--description":
            argv.append(draw(st.text(max_size=30)))
        elif flag in ("--model",):
            argv.append(draw(st.text(max_size=5)))
        elif flag not in ("--json", "--require-capacity", "--bogus"):
            argv.append(draw(numbers))
    if cmd == "bench-mass" and "--out" not in argv:
        argv += ["--out", f"{tmp}/bench"]
    return argv


def _argv_case(argv: list[str]) -> None:
    with tempfile.TemporaryDirectory() as tmp, contextlib.chdir(tmp):  # relative --out paths land in tmp
        (Path(tmp) / "afile").write_text("keep")
        (Path(tmp) / "dir").mkdir()
        (Path(tmp) / "dir" / "mine.txt").write_text("keep")
        argv = [a.replace("TMP", tmp) for a in argv]
        if argv[0] == "plan" and "--out" not in argv:
            argv += ["--out", f"{tmp}/out"]
        assert_contract(argv, "arguments")
        assert (Path(tmp) / "afile").read_text() == "keep" and (Path(tmp) / "dir" / "mine.txt").read_text() == "keep"


# -- plan directories ---------------------------------------------------------------------------
_PLAN: list[Path] = []


def good_plan() -> Path:
    if not _PLAN:
        out = Path(tempfile.mkdtemp(prefix="forte-fuzz-")) / "plan"
        assert main(["plan", str(TASKS / "hold.yaml"), "--method", "teaching", "--mass", "1", "--quiet",
                     "--no-figures", "--out", str(out), "--allow-infeasible", "--no-bound"]) == 0
        _PLAN.append(out)
    return _PLAN[0]


@st.composite
def tampered_plans(draw):
    target = draw(st.sampled_from(["plan.json", "plan.json", "trajectory.csv", "delete"]))
    if target == "plan.json":
        doc = json.loads((good_plan() / "plan.json").read_text())
        part = draw(st.sampled_from(["robot", "robot", "payload", "force", "status"]))
        if isinstance(doc.get(part), dict) and doc[part] and draw(st.booleans()):
            key = draw(st.sampled_from(sorted(doc[part])))
            doc[part][key] = draw(values)
        else:
            doc[part] = draw(values)
        try:
            text = json.dumps(doc)
        except (ValueError, TypeError):
            text = "{"
        return target, text.encode()
    if target == "trajectory.csv":
        lines = (good_plan() / "trajectory.csv").read_text().splitlines()
        kind = draw(st.sampled_from(["cell", "header", "row", "bytes", "rows"]))
        if kind == "cell":
            cells = lines[1].split(",")
            cells[draw(st.integers(0, len(cells) - 1))] = draw(st.sampled_from(["nan", "", "x", "1e999", "True"]))
            lines[1] = ",".join(cells)
        elif kind == "header":
            lines[0] = draw(st.text(max_size=40))
        elif kind == "row":
            lines.append(draw(st.text(max_size=40)))
        elif kind == "rows":
            lines += [lines[1]] * draw(st.integers(1, 3000))
        else:
            return target, "\n".join(lines).encode() + draw(st.binary(min_size=1, max_size=6))
        return target, "\n".join(lines).encode()
    return draw(st.sampled_from(["plan.json", "trajectory.csv"])), None


def _plan_case(target: str, content: bytes | None, flags: list[str]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / "plan"
        shutil.copytree(good_plan(), copy)
        if content is None:
            (copy / target).unlink()
        else:
            (copy / target).write_bytes(content)
        assert_contract(["simulate", str(copy), "--quiet", "--hold", "0.05", *flags], "plan directories")


# -- benchmark CSVs -----------------------------------------------------------------------------
@st.composite
def csvs(draw):
    header = draw(st.sampled_from(["image,description,mass_kg", "image_path,description,true_mass_kg",
                                   "image,mass_kg", "a,b,c", "", "image,description,mass_kg,extra"]))
    rows = []
    for _ in range(draw(st.integers(0, 4))):
        image = draw(st.sampled_from([str(IMAGES / "wine.png"), "missing.png", "", str(IMAGES)]))
        rows.append(",".join([image, draw(st.text(max_size=20)).replace("\n", " "),
                              draw(st.sampled_from(["1.2", "-1", "nan", "", "x", "0", "1e308"]))]
                             + draw(st.lists(st.sampled_from(["", "x"]), max_size=2))))
    text = "\n".join([header, *rows]) + "\n"
    encoding = draw(st.sampled_from(["utf-8", "utf-8", "latin-1", "utf-16"]))
    raw = text.encode(encoding, errors="replace")
    if draw(st.booleans()):
        i = draw(st.integers(0, len(raw)))
        raw = raw[:i] + draw(st.sampled_from([b"\x00", b"\xff\xfe", b"\r", b'"', b"\xe9"])) + raw[i:]
    return raw


def _csv_case(raw: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "data.csv"
        path.write_bytes(raw)
        assert_contract(["bench-mass", str(path), "--quiet", "--bootstrap", "20", "--workers", "1",
                         "--out", f"{tmp}/bench"], "benchmark CSVs")


# -- the tests: a fast sample by default, the full run with -m fuzz --------------------------------
def _family_tests(n: int):
    @fuzz_settings(n)
    @given(mutated_task())
    def tasks(case):
        _task_case(case[0], _dump(case[1]))

    @fuzz_settings(max(4, n // 3))
    @given(damaged_text())
    def texts(case):
        _task_case(*case)

    @fuzz_settings(n)
    @given(argvs())
    def arguments(argv):
        _argv_case(argv)

    @fuzz_settings(max(4, n * 2 // 3))
    @given(tampered_plans(), st.sampled_from([[], ["--mass", "0"], ["--no-force"]]))
    def plans(case, flags):
        _plan_case(case[0], case[1], flags)

    @fuzz_settings(max(4, n * 2 // 3))
    @given(csvs())
    def benchmarks(raw):
        _csv_case(raw)

    return tasks, texts, arguments, plans, benchmarks


_fast = _family_tests(FAST)
_full = _family_tests(FULL)


@pytest.mark.parametrize("index", range(5), ids=["tasks", "texts", "arguments", "plans", "benchmarks"])
def test_fuzz_sample(index):
    _fast[index]()


@pytest.mark.fuzz
@pytest.mark.parametrize("index", range(5), ids=["tasks", "texts", "arguments", "plans", "benchmarks"])
def test_fuzz_full(index):
    before = sum(CASES.values())
    _full[index]()
    assert sum(CASES.values()) - before >= FULL // 3 - 1


@pytest.mark.fuzz
def test_fuzz_full_count():
    """Runs last in the file: the full run generated at least 1000 cases."""
    print(f"fuzz cases: {dict(CASES)} = {sum(CASES.values())}")
    assert sum(CASES.values()) >= 1000


@pytest.mark.parametrize("argv", [[], ["plan", "/nonexistent.yaml"], ["simulate", "/nonexistent"],
                                  ["estimate-mass", "--image", "/missing.jpg"]])
def test_contract_through_a_real_process(argv):
    """A few cases through ``python -m forte.cli``: exit 2, one error line, no traceback."""
    proc = subprocess.run([sys.executable, "-m", "forte.cli", *argv], capture_output=True, text=True, timeout=120,
                          env={"PYTHONPATH": str(REPO / "src"), "PATH": "/usr/bin:/bin"})
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert [line for line in proc.stderr.splitlines() if line.startswith("forte: error:")].__len__() == 1
