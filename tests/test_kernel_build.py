"""How the kernels are built and compiled: the rfp-cone rays as one mapped function (the same
numbers as the rays written out), one C file per kernel compiled concurrently (the same numbers
as CasADi's virtual machine), the optimization level by file size."""

from __future__ import annotations

import shutil
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from conftest import random_configuration

import forte.planning.nlp.kernels as kernels
from forte.capability.polytope import cone_directions
from forte.exceptions import SolverError
from forte.planning.methods.catalog import METHODS
from forte.planning.nlp.kernels import KERNEL_NAMES, build_kernels, load_kernels
from forte.planning.terms.capability_terms import ConeVolume
from forte.settings import SolverOptions

needs_cc = pytest.mark.skipif(not (shutil.which("gcc") or shutil.which("cc")), reason="needs a C compiler")


def _close(a: ca.DM, b: ca.DM, rel: float = 1e-12) -> None:
    a, b = np.array(a, dtype=float), np.array(b, dtype=float)
    assert np.max(np.abs(a - b)) <= rel * max(1.0, np.max(np.abs(b)))


def _cone_inputs(robot, rng):
    """J, b = [tau_max - tau; tau_max + tau] and the rays around f of a random state (d > 0 on some)."""
    q = random_configuration(robot, rng)
    tau = robot.rnea(q[3:], 0.3 * rng.normal(size=7), 0.3 * rng.normal(size=7))
    b = np.r_[robot.torque_limits - tau, robot.torque_limits + tau]
    f = rng.normal(size=3) * 20
    return robot.arm_jacobian(q), b, cone_directions(f, 0.1, 4, 12).T, np.linalg.norm(f) + 10.0


def test_mapped_ray_sum_equals_the_rays_written_out(robot):
    """Value, gradient and Hessian in (J, b) of the mapped sum against the unrolled sum."""
    term = ConeVolume()
    J, b, D, s = ca.SX.sym("J", 3, 7), ca.SX.sym("b", 14), ca.SX.sym("D", 3, term.rays), ca.SX.sym("s")
    x = ca.vertcat(ca.vec(J), b)
    forms = []
    for total in (term.ray_sum(7)(J, b, D, s), term.ray_sum_unrolled(J, b, D, s)):
        H, g = ca.hessian(total, x)
        forms.append(ca.Function("f", [J, b, D, s], [total, g, H]))
    rng = np.random.default_rng(3)
    positive = 0
    for _ in range(20):
        args = _cone_inputs(robot, rng)
        mapped, unrolled = forms[0](*args), forms[1](*args)
        positive += float(unrolled[0]) > 0
        for a, u in zip(mapped, unrolled, strict=True):
            _close(a, u)
    assert positive >= 5  # the comparison saw active rays, not only clamped zeros


def test_cone_kernels_equal_the_unrolled_rays(robot, monkeypatch):
    """Every stage kernel of rfp-cone (cost, gradient, Hessian in the window z) is unchanged to
    1e-12 by the mapped form: same plans."""
    method, w = METHODS["rfp-cone"], None
    mapped = build_kernels(robot, method, w)

    # the same stage expression with the rays' sum written out instead of the mapped call
    monkeypatch.setattr(ConeVolume, "ray_sum", lambda self, n_arm: lambda *args: self.ray_sum_unrolled(*args))
    reference = build_kernels(robot, method, w)
    rng = np.random.default_rng(5)
    fn = mapped["stage_cost"]
    checked = 0
    for _ in range(6):
        q = random_configuration(robot, rng)
        z = np.r_[q, q + 0.01 * rng.normal(size=10), q + 0.02 * rng.normal(size=10)]
        f = np.array([rng.normal() * 5, rng.normal() * 5, 30.0])
        rays = ConeVolume().parameter_values("rays", f[None], np.array([10.0]))
        args = [z, 0.25, 0.25, f, 10.0, q, rays, np.abs(rng.normal(size=fn.size1_in(7)))]
        for name in ("stage_cost", "stage_grad", "stage_hess", "stage_terms"):
            n_in = mapped[name].n_in()
            _close(mapped[name](*args[:n_in]), reference[name](*args[:n_in]))
        checked += float(mapped["stage_terms"](*args[:7])[0]) < 1e6  # the cone term was not clamped
    assert checked >= 2


@needs_cc
def test_compiled_kernels_equal_the_virtual_machine(robot, tmp_path):
    """The library linked from one C file per kernel (compiled concurrently, -O1/-Og) computes
    what the SX functions compute, reverse modes included."""
    w = None
    lib = load_kernels(robot, "rfp-radius", w, SolverOptions(cache_dir=str(tmp_path)))
    assert lib.origin == "compiled"
    sx = build_kernels(robot, "rfp-radius", w)
    rng = np.random.default_rng(11)
    for name, fn in zip(KERNEL_NAMES, (lib.cost, lib.grad, lib.hess, lib.terms, lib.pose, lib.pose_jac,
                                       lib.pose_hess), strict=True):
        ref = sx[name]
        for _ in range(3):
            q = random_configuration(robot, rng)
            args = [rng.normal(size=ref.nnz_in(i)) for i in range(ref.n_in())]
            args[0] = np.r_[q, q, q] + 0.01 * rng.normal(size=ref.nnz_in(0)) if ref.nnz_in(0) == 30 else q
            if ref.n_in() > 2 and ref.nnz_in(1) == 1:
                args[1], args[2] = 0.2, 0.25  # time steps
            _close(fn(*args), ref(*args), rel=1e-9)
    adj = ca.external("adj1_stage_cost", str(next(tmp_path.glob("*.so"))))
    assert adj.n_in() == sx["stage_cost"].n_in() + 2


@needs_cc
def test_a_compiler_failure_is_a_solver_error(robot, tmp_path):
    with pytest.raises(SolverError, match="compiling the NLP kernels failed"):
        kernels._compile(build_kernels(robot, "manipulability"), tmp_path / "k.so",
                         shutil.which("false") or "false")
    assert not list(tmp_path.glob("*.so"))


def test_optimization_level_by_generated_file_size(tmp_path):
    def level(size: int) -> str:
        path = tmp_path / f"{size}.c"
        with path.open("wb") as fh:
            fh.truncate(size)
        return kernels._optimization(Path(path))

    assert level(10_000) == "-O1"
    assert level(kernels.LARGE_SOURCE_BYTES + 1) == "-Og"
    assert level(kernels.HUGE_SOURCE_BYTES + 1) == "-O0"
