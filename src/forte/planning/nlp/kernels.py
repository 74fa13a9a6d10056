"""Per-waypoint kernels of the NLP, built from a method's cost terms, compiled once and cached.

For one method the stage cost is ``sum_i w_i c_i(z_k, dt_{k-1}, dt_k, f_k, r_k, ...)`` over its
stage terms (:mod:`forte.planning.terms.costs`), with the window ``z_k = [q_{k-2}; q_{k-1}; q_k]``
and the weights ``w`` an input, so one compiled library serves every weight set. The kernels
are the stage cost, its gradient and Hessian in ``z``, the per-term values, and the pose
residual ``[p - p_d; vee(R_d^T R - R^T R_d) / 2]`` with its Jacobian and Lagrangian Hessian.

With a C compiler the kernels are generated as C (one file per kernel, compiled by concurrent
compiler processes, one per core, and linked into one library), compiled and cached on disk
(``$FORTE_CACHE`` or ``~/.cache/forte``) under a key made of the robot's fingerprint, the
method, what each term bakes in (:meth:`~forte.planning.terms.costs.CostTerm.baked`), the source of
the modules and term classes involved, and the CasADi and forte versions; without one they run
in CasADi's virtual machine (same results, slower).
"""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import shutil
import subprocess
import sys
import tempfile
import uuid
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca

from forte import __version__, progress
from forte.exceptions import SolverError
from forte.model.robot import MobileManipulator
from forte.model.twin import CasadiTwin
from forte.planning.methods.catalog import Method, get_method
from forte.planning.nlp.compile_target import signature, target_flags
from forte.planning.terms.costs import CostTerm, Stage
from forte.settings import SolverOptions
from forte.system import cpu_count

KERNEL_NAMES = ("stage_cost", "stage_grad", "stage_hess", "stage_terms", "pose", "pose_jac", "pose_hess")


@dataclass
class Kernels:
    """Per-waypoint functions the NLP is assembled from (SX, or compiled C loaded back)."""

    cost: ca.Function  # (z, dt_prev, dt, f, r, q_nom, *term parameters, w) -> weighted stage cost
    grad: ca.Function  # same inputs -> gradient w.r.t. z (3nq)
    hess: ca.Function  # same inputs -> Hessian w.r.t. z (3nq x 3nq, dense)
    terms: ca.Function  # same inputs without w -> value of each stage term
    pose: ca.Function  # (q, p_d, R_d) -> 6 pose residuals
    pose_jac: ca.Function  # -> 6 x nq
    pose_hess: ca.Function  # (q, p_d, R_d, lambda) -> nq x nq
    origin: str  # "compiled", "cached" or "virtual-machine"
    library: Path | None = None  # the compiled library (None in the virtual machine)


def cache_root(options: SolverOptions) -> Path:
    """Folder of the compiled kernels."""
    root = options.cache_dir or os.environ.get("FORTE_CACHE") or Path.home() / ".cache" / "forte"
    return Path(root)


def rotation_error_expr(R: Any, R_d: Any) -> Any:
    """``vee(R_d^T R - R^T R_d) / 2`` (zero iff R = R_d near the solution)."""
    E = R_d.T @ R - R.T @ R_d
    return ca.vertcat(E[2, 1], E[0, 2], E[1, 0]) / 2


def stage_terms(method: Method, settings: Mapping[str, Mapping[str, Any]] | None = None) -> tuple[CostTerm, ...]:
    """The method's stage terms (compiled into the kernels) with their ``settings`` (term ->
    {setting: value}, default: the terms' own), in summation order."""
    return tuple(t for t in method.cost_terms(settings) if t.kind == "stage")


def build_kernels(robot: MobileManipulator, method: str | Method,
                  settings: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, ca.Function]:
    """SX kernels of one method: a loop over its stage terms."""
    method = get_method(method)
    twin = CasadiTwin(robot)
    nq = robot.nq
    z = ca.SX.sym("z", 3 * nq)
    terms = stage_terms(method, settings)
    params = {name: ca.SX.sym(name, size) for t in terms for name, size in t.parameters}
    s = Stage(twin, z[:nq], z[nq:2 * nq], z[2 * nq:], ca.SX.sym("dt_prev"), ca.SX.sym("dt"),
              ca.SX.sym("f", 3), ca.SX.sym("r"), params, nominal=ca.SX.sym("q_nom", nq))
    values = [t.stage(s) for t in terms]
    weights = ca.SX.sym("w", len(terms))
    cost = ca.SX(0)
    for i, value in enumerate(values):
        cost = weights[i] * value if i == 0 else cost + weights[i] * value
    inputs = [z, s.dt1, s.dt0, s.f, s.r, s.nominal, *params.values()]
    H, grad = ca.hessian(cost, z)
    q, pd, Rd, lam = ca.SX.sym("q", nq), ca.SX.sym("p_d", 3), ca.SX.sym("R_d", 9), ca.SX.sym("lam", 6)
    R, p = twin.ee_pose(q)
    res = ca.vertcat(p - pd, rotation_error_expr(R, ca.reshape(Rd, 3, 3)))
    Hp, _ = ca.hessian(ca.dot(lam, res), q)
    return {
        "stage_cost": ca.Function("stage_cost", [*inputs, weights], [cost]),
        "stage_grad": ca.Function("stage_grad", [*inputs, weights], [grad]),
        "stage_hess": ca.Function("stage_hess", [*inputs, weights], [ca.densify(H)]),
        "stage_terms": ca.Function("stage_terms", inputs, [ca.vertcat(*values) if values else ca.SX(0, 1)]),
        "pose": ca.Function("pose", [q, pd, Rd], [res]),
        "pose_jac": ca.Function("pose_jac", [q, pd, Rd], [ca.densify(ca.jacobian(res, q))]),
        "pose_hess": ca.Function("pose_hess", [q, pd, Rd, lam], [ca.densify(Hp)]),
    }


def kernel_key(robot: MobileManipulator, method: str | Method,
               settings: Mapping[str, Mapping[str, Any]] | None = None) -> str:
    """Cache key: changes whenever anything compiled into the kernels changes: the robot, the
    method, and each stage term's baked settings (its dataclass fields, :meth:`CostTerm.baked`,
    as its declaration makes them from ``settings``), the terms' source."""
    method = get_method(method)
    baked = tuple((t.name, t.baked(), _class_digest(type(t))) for t in stage_terms(method, settings))
    text = repr((__version__, robot.fingerprint, method.name, baked, ca.__version__, _source_digest(),
                 signature(shutil.which("gcc") or shutil.which("cc"))))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


#: Measured first-compile times on a 2-core machine (benchmarks/bench_startup.py --compile),
#: shown as the expected time.
COMPILE_SECONDS = {"default": 6.0, "rfp-cone": 8.0}


def load_kernels(robot: MobileManipulator, method: str | Method, settings: Mapping[str, Mapping[str, Any]] | None,
                 options: SolverOptions) -> Kernels:
    """Kernels from the on-disk cache, compiling them first when needed (and possible).

    A cached library is loaded only when its size and sha256 match the record written next to it
    when it was compiled (``.so.json``): a truncated, empty, foreign or garbled file is never
    ``dlopen``-ed (a truncated one would kill the process with SIGBUS); it is rebuilt with one line
    of notice on stderr. When the cache folder cannot be written (read-only, a file, ...) or the
    compiler fails, the kernels run in CasADi's virtual machine, with a notice.
    """
    method = get_method(method)
    compiler = shutil.which("gcc") or shutil.which("cc")
    if options.codegen and compiler:
        lib = cache_root(options) / f"kernels_{method.name}_{kernel_key(robot, method, settings)}.so"
        fns = _load_verified(lib)
        origin = "cached"
        if fns is None:
            try:
                expected = COMPILE_SECONDS.get(method.name, COMPILE_SECONDS["default"])
                with progress.step(f"compiling the {method.name} kernels to C (once per robot and method)",
                                   expected):
                    _compile(build_kernels(robot, method, settings), lib, compiler)
                fns = _load_verified(lib, quiet=False)
                origin = "compiled"
            except (OSError, SolverError) as exc:
                reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc).splitlines()[0]
                notice(f"cannot build the kernel cache in {lib.parent} ({reason}); using CasADi's virtual "
                       "machine (slower, same results)")
        if fns is not None:
            return Kernels(*(fns[name] for name in KERNEL_NAMES), origin, lib)
    return Kernels(*(build_kernels(robot, method, settings)[name] for name in KERNEL_NAMES), "virtual-machine")


def notice(text: str) -> None:
    """One line on stderr about something forte repaired or worked around."""
    print(f"forte: notice: {text}", file=sys.stderr, flush=True)


def _record_path(lib: Path) -> Path:
    return lib.with_name(lib.name + ".json")


def _digest(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


#: Libraries verified in this process, by (path, size, mtime): hashing a large one on every load of
#: the same kernels (each plan of an experiment) is work done again.
_VERIFIED: set[tuple[str, int, int]] = set()


def verify_library(lib: Path) -> str | None:
    """None when ``lib`` matches its compile-time record, else why not (it must not be loaded)."""
    try:
        st = lib.stat()
        stamp = (str(lib), st.st_size, st.st_mtime_ns)
    except OSError:
        stamp = None
    if stamp is not None and stamp in _VERIFIED:
        return None
    problem = _check_record(lib)
    if problem is None and stamp is not None:
        _VERIFIED.add(stamp)
    return problem


def _check_record(lib: Path) -> str | None:
    """``verify_library`` without the in-process memo."""
    try:
        record = json.loads(_record_path(lib).read_text(encoding="utf-8"))
        size, digest = int(record["size"]), str(record["sha256"])
    except FileNotFoundError:
        return "no compile record"
    except (OSError, ValueError, KeyError, TypeError, RecursionError):
        return "unreadable compile record"
    try:
        st = lib.stat()
        if st.st_size != size:
            return f"size {st.st_size} bytes, compiled as {size}"
        if _digest(lib) != digest:
            return "content differs from the compiled library (sha256)"
    except OSError as exc:
        return f"unreadable ({exc.strerror or exc})"
    return None


def _load_verified(lib: Path, quiet: bool = True, names: tuple[str, ...] = KERNEL_NAMES
                   ) -> dict[str, ca.Function] | None:
    """The library's functions when it exists and verifies; else None (with a notice when it was
    there but bad)."""
    if not lib.exists() and not _record_path(lib).exists():
        return None
    problem = verify_library(lib) if lib.exists() else "library missing"
    if problem is None:
        try:
            return {name: ca.external(name, str(lib)) for name in names}
        except RuntimeError as exc:  # verified bytes that still do not load (another machine's build)
            problem = f"does not load ({str(exc).strip().splitlines()[-1][:120] if str(exc).strip() else 'error'})"
    if not quiet:
        raise SolverError(f"the freshly compiled kernels {lib} {problem}", status="codegen")
    notice(f"kernel cache entry {lib} is invalid ({problem}); rebuilding it")
    return None


#: Kernels whose reverse mode is generated next to them (``casadi.external`` finds it by name).
REVERSE_KERNELS = ("stage_cost", "pose", "clear_rows")


def _compile(functions: dict[str, ca.Function], lib: Path, compiler: str) -> None:
    """Generate one C file per kernel, compile them concurrently, link them into ``lib``."""
    lib.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=lib.parent) as tmp:
        folder = Path(tmp)
        sources = [_generate(name, fn, folder) for name, fn in functions.items()]
        objects = _compile_objects(sources, compiler)
        out = folder / "kernels.so"
        _run_compiler([compiler, "-shared", *map(str, objects), "-o", str(out), "-lm"])
        record = {"size": out.stat().st_size, "sha256": _digest(out), "casadi": ca.__version__, "forte": __version__}
        rec_tmp = folder / "record.json"
        rec_tmp.write_text(json.dumps(record) + "\n", encoding="utf-8")
        # atomic renames; the record goes first: a library without a matching record is rebuilt,
        # never loaded, so a concurrent run or a kill in between costs a rebuild at worst
        os.replace(rec_tmp, _record_path(lib))
        os.replace(out, lib)


def _generate(name: str, fn: ca.Function, folder: Path) -> Path:
    """``folder/name.c``: the kernel (and its reverse mode) with everything it calls."""
    gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    gen.add(fn)
    if name in REVERSE_KERNELS:
        gen.add(fn.reverse(1))
    gen.generate(f"{folder}{os.sep}")
    return folder / f"{name}.c"


def _compile_objects(sources: list[Path], compiler: str) -> list[Path]:
    """Object files of ``sources``, compiled by concurrent compiler processes (one per core),
    the largest first so that it does not finish last."""
    jobs = [[compiler, _optimization(src), *target_flags(compiler), "-fPIC", "-c", str(src), "-o",
             str(src.with_suffix(".o"))]
            for src in sorted(sources, key=lambda p: p.stat().st_size, reverse=True)]
    with ThreadPoolExecutor(max_workers=max(1, min(len(jobs), cpu_count()))) as pool:
        list(pool.map(_run_compiler, jobs))  # re-raises the first failure
    return [src.with_suffix(".o") for src in sources]


def _run_compiler(cmd: list[str]) -> None:
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SolverError(f"compiling the NLP kernels failed: {proc.stderr[-2000:]}", status="codegen")


#: Optimization by the size of a generated C file, measured on the 2 MB Hessian kernel of forte
#: (2 cores): -O1 compiles it in 6.7 s of CPU time, -Og in 4.7 s, -O0 in 2.4 s; the kernel
#: evaluates in 6.9 ms (-O1, -Og) against 24 ms (-O0) per N = 100 Hessian. Smaller files get -O1;
#: above ``HUGE_SOURCE_BYTES`` the optimizing passes' time and memory grow faster than the file
#: (gcc -O1 on a 24 MB file: over 5 minutes and 5 GB), so those get -O0.
LARGE_SOURCE_BYTES = 1_000_000
HUGE_SOURCE_BYTES = 4_000_000


def _optimization(src: Path) -> str:
    """``-O1`` for the usual kernels, ``-Og`` for large ones, ``-O0`` for huge ones (same results)."""
    size = src.stat().st_size
    return "-O0" if size > HUGE_SOURCE_BYTES else "-Og" if size > LARGE_SOURCE_BYTES else "-O1"


def _class_digest(cls: type) -> str:
    """Hash of the file that defines a term class, so editing a term (or a helper or constant
    next to it) invalidates its kernels, also for terms defined outside forte. A class whose
    source cannot be found (defined in a REPL) gets a fresh key each time: never a stale kernel."""
    try:
        path = inspect.getsourcefile(cls)
        text = Path(path).read_bytes() if path else None
    except (OSError, TypeError):
        text = None
    if text is None:
        return uuid.uuid4().hex[:12]
    return hashlib.sha256(text + cls.__qualname__.encode()).hexdigest()[:12]


def _source_digest() -> str:
    """Hash of the modules that define the kernels, so editing them invalidates the cache."""
    from forte.capability import metrics
    from forte.model import robot, twin
    from forte.planning.terms import capability_terms, costs, motion_terms

    digest = hashlib.sha256()
    for path in (__file__, costs.__file__, capability_terms.__file__, motion_terms.__file__, metrics.__file__,
                 twin.__file__, robot.__file__):
        digest.update(Path(path).read_bytes())
    return digest.hexdigest()[:12]
