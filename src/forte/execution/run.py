"""Running a plan through the Section 3.1 controllers in MuJoCo, and storing the outcome.

:func:`simulate_plan` reads a plan directory (``trajectory.csv`` + ``plan.json``, see
:func:`forte.io.plandir.write_plan_dir`), builds the model (:func:`forte.execution.model.build_sim_model`),
interpolates the waypoints (:mod:`forte.execution.reference`: a clamped spline or the plan's own
derivatives) and calls
:func:`run_simulation`, which runs one control step of :class:`forte.execution.control.ArmImpedance`
and :class:`forte.execution.control.BaseAdmittance` per MuJoCo step and judges every step
(:class:`forte.execution.judge.Judge`). When the plan has no payload (``payload.mass`` null) but
a task force, the force is an interaction with the environment: its reaction ``-f_d`` is
applied at the end effector (with ``force_feedforward=False`` the arm does not push back). A
simulated payload mass other than the plan's models an estimation error: the feedforward still
applies the plan's force. ``mass=0`` on a plan that carries a payload means no payload: no
payload body, and the feedforward keeps only the share of the plan's force that is the robot's
own end-effector load (the tool: ``m_tool / (m_payload + m_tool)``, none without a tool) unless
``force_feedforward`` says otherwise. A payload whose centre of mass is off the hand (``payload.com``,
``payload.inertia`` in plan.json) is simulated there, with its inertia
(:func:`forte.execution.bodies.carried_body`), and the feedforward applies the plan's whole wrench,
``J6^T (f, m)`` (:mod:`forte.execution.control`).

``sim.csv`` holds every ``record_every``-th control step: ``t``; the whole-body joint error
``e_x_b, e_y_b, e_yaw, e_q1..e_qn`` (``q_d - q``, yaw wrapped); the applied arm torques
``tau1..taun``; the saturation flags ``sat1..satn`` (OR-ed over the recording window);
the end-effector error ``ee_err_x/y/z`` (``p - p_d``, world frame) and its norm ``ee_err``;
the simulated whole-body joint positions ``x_b, y_b, yaw, q1..qn`` (the names of
``trajectory.csv``; yaw not wrapped) and velocities ``dx_b, dy_b, dyaw, dq1..dqn``.
``sim.json`` holds the verdict, the summary statistics and the gains used, and the contacts:
the plan's scene is built into the model (:mod:`forte.execution.contact`), a touch of the scene
or the floor fails the run (reason ``contact``), ``contact_checked`` says whether contacts were
on (off only for a robot whose URDF geometry MuJoCo cannot load, without a scene) and
``contacts`` lists every pair that touched: ``robot`` (a link, ``base`` or ``payload``),
``world`` (a scene body or ``floor``), ``first_time`` (s), ``first_force_N`` and
``peak_force_N`` (the normal force summed over the pair's contact points).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np

from forte.exceptions import InvalidInputError
from forte.execution.arm_spec import ARM_PREFIX, geometry_loadable
from forte.execution.base_drive import FloorDrive
from forte.execution.base_events import BaseMonitor, BaseThresholds
from forte.execution.bodies import carried_body
from forte.execution.contact import touches
from forte.execution.contact_objects import ContactRig, rig_for
from forte.execution.control import ArmCommand, ArmImpedance, BaseAdmittance, ControlGains, Reference
from forte.execution.floor_base import check_base_model
from forte.execution.gains import default_gains, describe_gains, resolve_gains, sampled_loop_radius_at
from forte.execution.grasp import attach_at_grasp, attach_facts, chained
from forte.execution.judge import Judge, SimResult, Thresholds
from forte.execution.model import SimModel, build_sim_model
from forte.execution.reference import plan_reference
from forte.execution.reference_force import along_reference, carried_mass
from forte.execution.render import FrameRecorder, FrameSink, LiveViewer
from forte.execution.run_log import RunLog, write_results
from forte.io.plandir import read_plan_dir
from forte.model.presets import with_torque_limits
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.trajectory import joint_limits
from forte.planning.planner import Plan
from forte.validation import FloatArray, as_positive, payload_mass


def check_mass(mass: Any) -> float:
    """A payload mass >= 0 kg (``InvalidInputError`` naming ``mass`` otherwise)."""
    if mass is None:
        raise InvalidInputError("mass: expected a number >= 0 kg, got None")
    return payload_mass(mass, "mass", allow_zero=True)


class _ControlStep:
    """One control step: read the end effector, command arm and base, apply the reaction force."""

    def __init__(self, sim: SimModel, gains: ControlGains, reaction_force: bool) -> None:
        self.sim = sim
        self.arm = ArmImpedance(sim.robot, gains, armature=sim.armature)
        self.base = BaseAdmittance(gains, sim.timestep)
        self.reaction_force = reaction_force
        self.ee_body = int(sim.model.site_bodyid[sim.ee_site])
        self.drive = FloorDrive(sim.floor) if sim.floor is not None else None

    def __call__(self, k: int, q: FloatArray, dq: FloatArray, ref: Reference) -> tuple[FloatArray, float, ArmCommand]:
        """Set the controls for step ``k``; return the end-effector error, its tilt and the arm command."""
        sim, m, d = self.sim, self.sim.model, self.sim.data
        q_d = ref.q[k]
        T_d = sim.robot.ee_pose(q_d)
        T = sim.ee_pose()
        ee_err = T[:3, 3] - T_d[:3, 3]
        tilt = float(np.arccos(np.clip(T[:3, 2] @ T_d[:3, 2], -1.0, 1.0)))
        f_d = ref.f[k]
        wrench = ref.m is not None  # a moment too: the feedforward is J6^T (f, m)
        J = sim.ee_jacobian(angular=wrench)
        cmd = self.arm.command(q[N_BASE:], dq[N_BASE:], q_d[N_BASE:], ref.dq[k, N_BASE:],
                               ref.ddq[k, N_BASE:], J, np.r_[f_d, ref.m[k]] if wrench else f_d,
                               (q[:N_BASE], dq[:N_BASE], ref.ddq[k, :N_BASE]))
        v_cmd = self.base.command(q[:N_BASE], dq[:N_BASE], q_d[:N_BASE], ref.dq[k, :N_BASE])
        if sim.robot.base == "fixed":  # a fixed base is held: its velocity actuators commanded zero
            v_cmd = np.zeros(N_BASE)
        d.ctrl[sim.arm_act] = cmd.tau
        if self.drive is not None:  # a base on the floor: its wheels or its push (forte.execution.base_drive)
            d.ctrl[sim.floor.actuators] = self.drive.command(q[:N_BASE], dq[:N_BASE], q_d[:N_BASE],
                                                             ref.dq[k, :N_BASE], v_cmd)
        else:
            d.ctrl[sim.base_act] = v_cmd
        if self.reaction_force:
            d.qfrc_applied[:] = 0.0
            mujoco.mj_applyFT(m, d, -f_d, np.zeros(3), T[:3, 3].copy(), self.ee_body, d.qfrc_applied)
        return ee_err, tilt, cmd


def run_simulation(
    sim: SimModel,
    reference: Reference,
    *,
    gains: ControlGains | None = None,
    thresholds: Thresholds | None = None,
    reaction_force: bool = False,
    record_every: int = 10,
    stop_on_failure: bool = False,
    sinks: Sequence[FrameSink] = (),
    after_step: Callable[[int, FloatArray, FloatArray], None] | None = None,
    rig: ContactRig | None = None,
    base_thresholds: BaseThresholds | None = None,
) -> SimResult:
    """Run the controllers on ``sim`` along ``reference`` (sampled at every control step).

    The simulation starts at ``reference.q[0]`` at rest; one control step per MuJoCo step
    (``reference.t`` must be ``k * timestep``). With ``reaction_force`` the environment's
    reaction ``-f_d`` is applied at the end-effector point. Each of ``sinks`` (offscreen
    recorder, live viewer) captures the state every ``sink.every`` steps. ``gains`` default to
    :func:`forte.execution.gains.default_gains` at the start configuration. ``after_step(k, q,
    dq)`` runs after every step (state before it); it may change the reference's future rows
    (closed-loop re-planning, :mod:`forte.execution.closed_loop`). ``rig``: a contact task's
    object (:mod:`forte.execution.contact_objects`), its forces applied before and measured after
    every step; an object that ends off the plan fails the run (reason ``object``). A base on the
    floor (``sim.floor``) is also judged on tip-over, slip and leaving its path
    (:mod:`forte.execution.base_events`, criteria ``base_thresholds``).
    """
    gains = gains or default_gains(sim.robot, reference.q[0, N_BASE:], sim.armature)
    th = thresholds or Thresholds()
    dt = sim.timestep
    control = _ControlStep(sim, gains, reaction_force)
    judge = Judge(th, dt, sim.robot.n_arm, sim.payload_mass > 0)
    log = RunLog(reference.t.size, record_every, sim.robot.nq, control.arm.tau_max)
    base = None if sim.floor is None else BaseMonitor(sim, base_thresholds or BaseThresholds(), log.rec_idx)
    sim.set_state(reference.q[0])
    if rig is not None:
        rig.bind(sim)
    contacts = sim.scene is not None
    start = time.perf_counter()
    steps_run = 0
    for k in range(reference.t.size):
        q, dq = sim.state()
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(dq))):
            judge.fail(k * dt, "unstable", f"non-finite state at t = {k * dt:.3f} s")
            break
        ee_err, tilt, cmd = control(k, q, dq, reference)
        judge.step(k * dt, ee_err, tilt, cmd.saturated)
        log.add(k, q, dq, reference.q[k], ee_err, cmd)
        for sink in sinks:
            if k % sink.every == 0:
                sink.capture(sim)
        steps_run += 1
        if stop_on_failure and judge.reason is not None:
            break
        if rig is not None:
            rig.apply(k * dt)
        mujoco.mj_step(sim.model, sim.data)
        if rig is not None:
            rig.measure(k * dt)
        if contacts and sim.data.ncon:  # the contacts of the state at step k
            judge.touch(k * dt, touches(sim.model, sim.data, ARM_PREFIX))
        if base is not None and base.step(k, q, dq, reference.q[k], judge):
            break  # the base tipped over and fell
        if after_step is not None:
            after_step(k, q, dq)
    wall = time.perf_counter() - start
    if rig is not None:
        facts, failure = rig.outcome()
        if failure is not None:
            judge.fail(steps_run * dt, "object", failure)
    summary = {"duration": float(steps_run * dt), "timestep": dt, "steps": steps_run, "wall_time_s": wall,
               "payload_mass": sim.payload_mass, **log.summary(steps_run), "thresholds": asdict(th),
               "contact_checked": contacts, "contacts": judge.contact_list(),
               "base": {"model": "kinematic"} if base is None else base.summary()}
    if rig is not None:
        summary["contact_task"] = facts
    columns = {**log.columns(reference.t), **({} if base is None else base.columns(log.rows))}
    return SimResult(judge.reason is None, judge.reason, judge.time, judge.detail or "all criteria met", columns,
                     summary)


def simulate_plan(
    plan_dir: str | Path, mass: float | None = None, *, force_feedforward: bool | None = None,
    out_dir: str | Path | None = None, gains: ControlGains | Mapping[str, Any] | None = None,
    thresholds: Thresholds | None = None, torque_limits: Any = None, hold: float = 1.0, timestep: float = 1e-3,
    record_every: int = 10, stop_on_failure: bool = False, frames_dir: str | Path | None = None,
    video: str | Path | None = None, fps: float = 30.0, viewer: bool = False, write: bool = True, replan: Any = None,
    reference: str = "spline", mpc: Any = None, base_model: str = "kinematic", base_thresholds: Any = None,
) -> SimResult:
    """Simulate the plan in ``plan_dir`` and (with ``write``) store ``sim.csv`` and ``sim.json``.

    Args:
        plan_dir: Folder with ``trajectory.csv`` and ``plan.json``.
        mass: True payload mass in the simulation (kg); default: the plan's ``payload.mass`` (none
            when null). Another mass > 0 models an estimation error, ``0`` no payload (module docstring).
        force_feedforward: ``tau_F = J^T f_d`` on (True, the plan's whole force) or off (False);
            default (None): on (for ``mass=0`` on a payload plan, the tool's share: module docstring).
        out_dir: Where to write the results (default ``plan_dir``).
        gains: Controller gains, or a ``controller:`` mapping for
            :func:`forte.execution.gains.gains_from_mapping` (rule inertia at the plan's start);
            default: :func:`forte.execution.gains.default_gains` (Franka's on the Panda, the
            4 Hz rule on any other arm).
        thresholds: Failure criteria (defaults documented there).
        torque_limits: Override the robot's limits (Nm, per arm joint), e.g. for stress tests.
        hold: Seconds simulated after the last waypoint, holding it.
        timestep: Simulation and control period (s); 1 ms = 1 kHz.
        record_every: Log every n-th control step (saturation flags OR-ed over the window).
        stop_on_failure: Stop at the first failure instead of running to the end.
        frames_dir: Offscreen rendering to PNG frames in this folder (at ``fps``).
        video: Offscreen rendering to this mp4 file (at ``fps``).
        fps: Frame rate of ``frames_dir`` and ``video``.
        viewer: Show the run in MuJoCo's interactive viewer, paced to real time; after the
            run (and after writing the results) wait until the user closes the window.
        replan: :class:`~forte.execution.closed_loop.ReplanOptions` to identify the payload
            online and re-plan the remaining motion (:mod:`forte.execution.closed_loop`).
        mpc: :class:`~forte.execution.mpc.MpcOptions` to run under model-predictive control: the
            remaining motion re-solved at a fixed rate from the measured state, with online
            identification and asynchronous payload estimates (:mod:`forte.execution.mpc`); not with ``replan``.
        reference: ``"spline"`` (clamped cubic spline through the waypoints) or ``"plan"`` (the plan's
            own backward-difference velocities and accelerations), see :mod:`forte.execution.reference`.
        base_model: ``"kinematic"`` or ``"floor"`` (:mod:`~forte.execution.floor_base`; ``base_thresholds``).
        write: Write ``sim.csv``/``sim.json``, after the run, each through a temporary file and a
            rename: an interrupted or crashed run never replaces earlier results.

    Examples:
        Hold the home pose for 0.2 s, no payload:

        >>> import tempfile, forte
        >>> from forte.io.plandir import write_plan_dir
        >>> robot = forte.default_robot()
        >>> plan_dir = write_plan_dir(tempfile.mkdtemp() + "/home", robot, [0.0], [robot.home()])
        >>> forte.simulate(plan_dir, hold=0.2, write=False).success
        True

    Raises:
        TaskFileError: malformed plan directory; InvalidInputError: bad gains mapping or
        arguments; SimulationError: model or rendering problems, no display for ``viewer``.
    """
    _check_loops(base_model, replan, mpc)
    plan = read_plan_dir(plan_dir)
    offscreen = frames_dir is not None or video is not None
    run = _setup(plan, mass, force_feedforward, gains, torque_limits, hold, timestep, reference, offscreen or viewer,
                 base_model)
    recorder = FrameRecorder(run.sim, _optional_path(frames_dir), _optional_path(video), fps) if offscreen else None
    live = LiveViewer(run.sim) if viewer else None
    loop = _closed_loop(Path(plan_dir), plan, run.sim, run.reference, replan, mpc)
    attach = attach_at_grasp(plan_dir, run.sim, plan)  # pick and place: the payload from the grasp on
    result = run_simulation(
        run.sim, run.reference, gains=run.gains, thresholds=thresholds, reaction_force=_reaction_force(plan),
        record_every=record_every, stop_on_failure=stop_on_failure, base_thresholds=base_thresholds,
        sinks=[s for s in (recorder, live) if s is not None], after_step=chained(attach, loop), rig=run.rig)
    result.summary.update(_run_facts(plan, Path(plan_dir), run, reference) | attach_facts(attach))
    if loop is not None:
        result.summary["mpc" if mpc is not None else "replanning"] = loop.summary()
    if recorder is not None:
        result.summary["rendered"] = [str(p) for p in recorder.finish()]
    if write:
        write_results(result, Path(plan_dir) if out_dir is None else Path(out_dir))
    if live is not None:  # after writing: the viewer waits for its window to close
        live.finish()
    return result


class _Run(NamedTuple):
    """What a run of a plan is built from (:func:`_setup`)."""

    sim: SimModel
    gains: ControlGains
    reference: Reference  # sampled at every control step, ``hold`` s past the plan's end
    force_share: float  # the share of the plan's force the feedforward applies
    rig: ContactRig | None  # a contact task's object


def _setup(plan: Plan, mass: float | None, force_feedforward: bool | None,
           gains: ControlGains | Mapping[str, Any] | None, torque_limits: Any, hold: float, timestep: float,
           reference: str, meshes: bool, base_model: str = "kinematic") -> _Run:
    """The MuJoCo model of ``plan`` carrying the true payload ``mass``, the controller's gains and
    the reference (arguments as in :func:`simulate_plan`; ``meshes`` for rendering)."""
    robot = plan.robot if torque_limits is None else with_torque_limits(plan.robot, torque_limits)
    true_mass = plan.payload.mass if mass is None else check_mass(mass)
    force_feedforward, force_share = _feedforward(plan, robot, mass is not None and true_mass == 0.0,
                                                  force_feedforward)
    hold = as_positive(hold, "hold", allow_zero=True)
    # the robot's end-effector load that the plan's force includes (tool_force_mass) is carried
    # physically with the payload, at the payload's centre of mass with its inertia: one welded body
    carried, com, inertia = carried_body(true_mass or 0.0, plan.payload.com, plan.payload.inertia,
                                         robot.tool_force_mass if plan.payload.mass is not None else 0.0)
    # contact with the scene and the floor, unless the URDF's geometry cannot be loaded and there is no scene
    scene = plan.scene if plan.scene or geometry_loadable(robot) else None
    # a contact task's object (forte.execution.contact_objects): built in, its contact modelled
    rig = rig_for(plan.contact, robot, plan.q, plan.force)
    sim = build_sim_model(robot, carried, payload_com=com, payload_inertia=inertia, meshes=meshes,
                          timestep=timestep, scene=scene, decorate=None if rig is None else rig.decorate,
                          base_model=base_model)
    gains = resolve_gains(gains, sim, plan.q[0, N_BASE:], force_feedforward)
    # the moment is the payload's alone: none without it
    moment_share = 0.0 if mass is not None and true_mass == 0.0 and force_feedforward is None else force_share
    ref = _plan_reference(plan, sim.timestep, hold, force_share, reference, moment_share, gains.force_along_reference)
    return _Run(sim, gains, ref, force_share, rig)


def _closed_loop(plan_dir: Path, plan: Plan, sim: SimModel, reference: Reference, replan: Any, mpc: Any) -> Any:
    """The ``after_step`` of a re-planning or MPC run (it may rewrite ``reference``), None open-loop."""
    if replan is not None:
        from forte.execution.closed_loop import make_replan_loop

        return make_replan_loop(plan_dir, plan, sim, reference, replan)
    if mpc is not None:
        from forte.execution.mpc import make_mpc_loop

        return make_mpc_loop(plan_dir, plan, sim, reference, mpc)
    return None


def _reaction_force(plan: Plan) -> bool:
    """No payload, no contact task, a force: an interaction, the environment pushes back with ``-f_d``."""
    return (plan.payload.mass is None and plan.contact is None and plan.force is not None
            and bool(np.any(plan.force.f)))


def _feedforward(plan: Plan, robot: MobileManipulator, unloaded: bool, wanted: bool | None) -> tuple[bool, float]:
    """Whether the force feedforward is on, and the share of the plan's force it applies."""
    if wanted is not None:
        return wanted, 1.0
    if unloaded and plan.payload.mass is not None:
        # no payload: the tool the plan's force includes is still carried, so the feedforward
        # keeps the tool's share of that force, m_tool / (m_payload + m_tool) (none without a tool)
        share = robot.tool_force_mass / (plan.payload.mass + robot.tool_force_mass)
        return share > 0.0, share
    return True, 1.0


def _check_loops(base_model: str, replan: Any, mpc: Any) -> None:
    """At most one closed loop; a known base model; the floor base open-loop only (the closed loops'
    identification reads the kinematic base's joints)."""
    if replan is not None and mpc is not None:
        raise InvalidInputError("replan, mpc: expected one closed loop, got both")
    if check_base_model(base_model) == "floor" and (replan is not None or mpc is not None):
        raise InvalidInputError("base_model: the floor base runs open-loop plans only (not with re-planning or MPC); "
                                "use kinematic")


def _optional_path(path: str | Path | None) -> Path | None:
    return None if path is None else Path(path)


def _run_facts(plan: Plan, plan_dir: Path, run: _Run, reference: str) -> dict[str, Any]:
    """What ``sim.json`` records about the plan, the model, the controller and the reference of a run."""
    q_a0 = plan.q[0, N_BASE:]
    sim, gains = run.sim, run.gains
    return {
        "plan_dir": str(plan_dir.resolve()), "plan_method": plan.method, "plan_status": plan.status,
        "plan_verdict": plan.label,
        "plan_verdict_failed": list(plan.verdict.failed) if plan.verdict is not None else None,
        "plan_mass": plan.payload.mass, "force_feedforward": gains.force_feedforward, "armature": sim.armature.tolist(),
        "torque_limits": sim.robot.torque_limits.tolist(),  # the plan's, or simulate_plan's torque_limits
        "gains": describe_gains(gains),
        "sampled_loop_radius_start": sampled_loop_radius_at(sim.robot, gains, q_a0, sim.armature, sim.timestep),
        "force_feedforward_share": run.force_share if gains.force_feedforward else 0.0,
        "reference": reference,
    }


def _plan_reference(plan: Plan, dt: float, hold: float, force_share: float = 1.0,
                    kind: str = "spline", moment_share: float = 1.0, along: bool = False) -> Reference:
    """The plan's reference at every control step ``t_0 + k dt`` up to ``hold`` s after its end
    (the force times ``force_share``; the moment, when the plan has one, times ``moment_share``);
    ``along``: a payload's force ``m (p'' - g)`` on the reference's own hand acceleration
    (:mod:`forte.execution.reference_force`; not for a payload off the hand, whose moment is planned too)."""
    steps = int(round((plan.t[-1] - plan.t[0] + hold) / dt)) + 1
    times = plan.t[0] + dt * np.arange(steps)
    force_t, force = (None, None) if plan.force is None else (plan.force.t, force_share * np.asarray(plan.force.f))
    moment = None if plan.force is None or plan.force.m is None else moment_share * np.asarray(plan.force.m)
    ref = plan_reference(plan.t, plan.q, times, force_t, force, kind, moment, joint_limits(plan.robot))
    # a payload off the hand (a moment) keeps force and moment as planned, the two consistent
    mass = None if force is None or moment is not None or not along else \
        carried_mass(plan.robot, plan.t, plan.q, plan.force.f)
    return ref if mass is None else replace(ref, f=force_share * along_reference(plan.robot, ref.t, ref.q, mass))


#: ``forte.simulate``: the public name of :func:`simulate_plan`.
simulate = simulate_plan
