"""``forte demo``: the residual force polytope and margin of the default robot at rest."""

from __future__ import annotations

import argparse
import json

import numpy as np

from forte.capability.metrics import (
    CapabilityParameters,
    capability_margin,
    capability_penalty,
    manipulability,
    normalization,
)
from forte.capability.polytope import (
    directional_capacity,
    halfspaces,
    inscribed_radius,
    residual_margins,
    vertices,
)
from forte.force.taskforce import DEFAULT_RADIUS, payload_force
from forte.model.robot import default_robot


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo",
        help="print the residual force polytope of the built-in robot at its home pose",
        description="Static residual force polytope, margin and manipulability of the built-in "
        "MOCA-like robot at its home pose, holding a payload of --mass kg.",
    )
    p.add_argument("--mass", type=float, default=2.7, help="payload mass in kg (default 2.7)")
    p.add_argument("--radius", type=float, default=DEFAULT_RADIUS, help="uncertainty radius, N")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=run_demo)


def run_demo(args: argparse.Namespace) -> int:
    from forte.exceptions import InvalidInputError
    from forte.validation import payload_mass

    payload_mass(args.mass, "--mass")
    if not 0 <= args.radius <= 1e6:
        raise InvalidInputError(f"--radius: expected a number in [0, 1e6] N, got {args.radius}")
    robot = default_robot()
    q = robot.home()
    params = CapabilityParameters()
    zeros = np.zeros(robot.n_arm)
    tau = robot.rnea(q[3:], zeros, zeros)
    J = robot.arm_jacobian(q)
    plus, minus = residual_margins(tau, robot.torque_limits)
    A1, b1 = halfspaces(J, plus, minus, alpha=1.0)
    A, b = halfspaces(J, plus, minus, alpha=params.alpha)
    # the required force carries the robot's end-effector load too, as a planned task's does
    load = args.mass + robot.tool_force_mass
    task = payload_force([0.0], [robot.ee_position(q)], load, args.radius, robot.gravity)
    f, r = task.f[0], task.r[0]
    d = float(capability_margin(A, b, f, r))
    c = float(capability_penalty(d, normalization(f, r), params.kappa, params.max_exponent))
    verts = vertices(A1, b1)
    report = {
        "robot": robot.name,
        "q": q.tolist(),
        "ee_position": robot.ee_position(q).tolist(),
        "nominal_torque": tau.tolist(),
        "torque_limits": robot.torque_limits.tolist(),
        "desired_force": f.tolist(),
        "tool_force_mass": robot.tool_force_mass,
        "radius": float(r),
        "alpha": params.alpha,
        "margin_d": d,
        "penalty_c": c,
        "directional_capacity_up": float(directional_capacity(A1, b1, [0, 0, 1])),
        "inscribed_radius": float(inscribed_radius(A1, b1)),
        "manipulability": float(manipulability(J)),
        "rfp_vertices": len(verts),
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    np.set_printoptions(precision=3, suppress=True)
    print(f"robot {robot.name} at home pose, end effector at {np.round(report['ee_position'], 3)} m")
    print(f"nominal torque (Nm): {tau}")
    print(f"torque limits (Nm):  {robot.torque_limits}")
    print(f"residual force polytope (alpha = 1): {len(verts)} vertices, "
          f"inscribed radius {report['inscribed_radius']:.1f} N, "
          f"capacity straight up {report['directional_capacity_up']:.1f} N")
    print(f"payload {args.mass} kg + end-effector load {robot.tool_force_mass:g} kg -> desired force {f} N, "
          f"ball radius {args.radius} N")
    verdict = "inside" if d >= 0 else "NOT inside"
    print(f"margin d = {d:.2f} N (alpha = {params.alpha}): the force ball is {verdict} the RFP; "
          f"penalty c = {c:.3f}")
    print(f"manipulability mu = {report['manipulability']:.4f}")
    return 0
