"""The compiled-kernel cache: verified before loading, rebuilt when bad, in-memory when unwritable."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import forte.planning.nlp.kernels as kernels
from forte.planning.nlp.kernels import load_kernels, verify_library
from forte.planning.tasks.tasks import load_task
from forte.settings import SolverOptions

pytestmark = pytest.mark.skipif(not (shutil.which("gcc") or shutil.which("cc")), reason="needs a C compiler")
REPO = Path(__file__).resolve().parents[1]
HOLD = REPO / "examples" / "tasks" / "hold.yaml"


@pytest.fixture(scope="module")
def good(robot, tmp_path_factory):
    """A cache folder holding one freshly compiled library and its record."""
    root = tmp_path_factory.mktemp("cache")
    k = load_kernels(robot, "manipulability", None, SolverOptions(cache_dir=str(root)))
    assert k.origin == "compiled"
    (lib,) = root.glob("*.so")
    assert verify_library(lib) is None
    return lib


def _copy(good: Path, dest: Path) -> Path:
    dest.mkdir(parents=True, exist_ok=True)
    shutil.copy(good, dest / good.name)
    shutil.copy(good.with_name(good.name + ".json"), dest / (good.name + ".json"))
    return dest / good.name


@pytest.mark.parametrize("damage", ["truncated", "empty", "garbage", "no-record", "bad-record"])
def test_a_bad_entry_is_never_loaded_and_is_rebuilt(robot, good, tmp_path, monkeypatch, capsys, damage):
    lib = _copy(good, tmp_path / "c")
    data = good.read_bytes()
    if damage == "truncated":
        lib.write_bytes(data[: len(data) // 2])
    elif damage == "empty":
        lib.write_bytes(b"")
    elif damage == "garbage":
        lib.write_bytes(os.urandom(len(data)))  # same size, other content
    elif damage == "no-record":
        lib.with_name(lib.name + ".json").unlink()
    else:
        lib.with_name(lib.name + ".json").write_text("{not json")
    assert verify_library(lib) is not None
    loaded = []
    real_external = kernels.ca.external
    monkeypatch.setattr(kernels.ca, "external", lambda name, path: loaded.append(path) or real_external(name, path))

    def fake_compile(functions, target, compiler):  # a rebuild, without 10 s of gcc
        assert loaded == []  # the damaged library was never dlopen-ed
        _copy(good, target.parent)

    monkeypatch.setattr(kernels, "_compile", fake_compile)
    k = load_kernels(robot, "manipulability", None, SolverOptions(cache_dir=str(tmp_path / "c")))
    assert k.origin == "compiled" and verify_library(lib) is None
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("forte: notice: kernel cache entry") and "rebuilding" in err


def test_cache_dir_that_is_a_file_falls_back_to_the_virtual_machine(robot, tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("keep")
    k = load_kernels(robot, "manipulability", None, SolverOptions(cache_dir=str(afile)))
    assert k.origin == "virtual-machine" and afile.read_text() == "keep"
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "virtual machine" in err


def test_read_only_cache_dir_falls_back_to_the_virtual_machine(robot, tmp_path, monkeypatch, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    if os.geteuid() == 0:  # root writes through permissions: make the write fail as it would
        monkeypatch.setattr(kernels.Path, "mkdir", lambda *a, **k: (_ for _ in ()).throw(
            PermissionError(13, "Permission denied")))
    else:
        ro.chmod(0o555)
    try:
        k = load_kernels(robot, "manipulability", None, SolverOptions(cache_dir=str(ro / "sub")))
    finally:
        ro.chmod(0o755)
    assert k.origin == "virtual-machine"
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Permission denied" in err


def test_a_verified_entry_loads_without_notice(robot, good, tmp_path, capsys):
    _copy(good, tmp_path / "c")
    k = load_kernels(robot, "manipulability", None, SolverOptions(cache_dir=str(tmp_path / "c")))
    assert k.origin == "cached" and capsys.readouterr().err == ""


@pytest.mark.slow
def test_truncated_cache_is_no_sigbus_end_to_end(tmp_path):
    """The measured failure: a truncated library made ``forte plan`` die with SIGBUS (exit 135)."""
    # the library `forte plan hold.yaml` looks for: its robot and its weights (a hold task uses
    # the ``authors-hold`` set, not the default weights of the ``good`` fixture's library)
    task = load_task(HOLD)
    cache = tmp_path / "cache"
    assert load_kernels(task.robot, "manipulability", task.settings, SolverOptions(cache_dir=str(cache))).origin \
        == "compiled"
    (lib,) = cache.glob("*.so")
    lib.write_bytes(lib.read_bytes()[:4096])
    env = {**os.environ, "FORTE_CACHE": str(cache), "PYTHONPATH": str(REPO / "src")}
    proc = subprocess.run([sys.executable, "-m", "forte.cli", "plan", str(HOLD),
                           "--method", "manipulability", "--mass", "1", "--no-figures", "--quiet",
                           "--allow-infeasible", "--no-bound",
                           "--out", str(tmp_path / "out")], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "rebuilding" in proc.stderr and "Traceback" not in proc.stderr
    assert verify_library(lib) is None


def test_the_processor_specific_build_is_in_the_cache_key(robot, monkeypatch):
    """``-march=native`` (where the compiler takes it) is keyed by the compiler's own expansion of
    it, so a cache shared between machines never loads another processor's build; with
    ``FORTE_PORTABLE_KERNELS=1`` the build and the key are the portable ones."""
    from forte.planning.nlp import compile_target
    from forte.planning.nlp.kernels import kernel_key

    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None or compile_target._native(compiler) is None:
        pytest.skip("no compiler that accepts -march=native")
    monkeypatch.delenv(compile_target.PORTABLE_ENV, raising=False)
    native_flags, native_sig, native_key = (compile_target.target_flags(compiler),
                                            compile_target.signature(compiler), kernel_key(robot, "forte"))
    assert native_flags == ("-march=native",) and native_sig != "portable"
    monkeypatch.setenv(compile_target.PORTABLE_ENV, "1")
    assert compile_target.target_flags(compiler) == () and compile_target.signature(compiler) == "portable"
    assert kernel_key(robot, "forte") != native_key
    # another processor's expansion of the flag is another key
    monkeypatch.delenv(compile_target.PORTABLE_ENV)
    monkeypatch.setattr(compile_target, "_native", lambda c: "cc1 -march=another-cpu -mno-avx")
    assert compile_target.signature(compiler) not in (native_sig, "portable")
    assert kernel_key(robot, "forte") != native_key
    assert compile_target.target_flags(None) == ()
