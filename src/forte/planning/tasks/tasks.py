"""Task files: YAML descriptions of a planning problem, validated with precise errors.

A task names the robot (default: the built-in one), the mode (``trajectory`` or ``hold``), the
end-effector path or pose, the payload (a mass, or a description and an image for the
estimator) or a force profile given directly, the uncertainty radius, weights, torque limits
and solver options. Every error names the file, the field and what was expected. See
``examples/tasks/*.yaml`` and ``docs/task-files.md`` (generated from :mod:`forte.planning.tasks.task_fields`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from forte.exceptions import TaskFileError
from forte.force.contact import Carry, Contact, contact_force
from forte.force.payload import Payload
from forte.force.taskforce import (
    AUTHORS_FORCE_RAMP_S,
    DEFAULT_RADIUS,
    FORCE_MODELS,
    RADIUS_RULES,
    TaskForce,
    attached_from,
    authors_force,
    mass_range_radius,
    payload_force,
)
from forte.force.wrench import with_payload_moment
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene
from forte.model.trajectory import StartMotion, quintic_path, start_through
from forte.planning.tasks.contact_section import read_contact
from forte.planning.tasks.goals import GOAL_MAX_ITER, GOAL_SOLVE_BUDGET_S, Goal, goal_section, goal_targets
from forte.planning.tasks.keep_level import KeepLevel, keep_level_section
from forte.planning.tasks.motion_section import force_profile, limits_section, path_targets, start_configuration
from forte.planning.tasks.paths import (
    ForceAt,
    HeldPath,
    TargetsAt,
    ending_at_rest,
    force_with_hold,
)
from forte.planning.tasks.payload_section import payload_section
from forte.planning.tasks.scene_section import DEFAULT_CLEARANCE, check_floor, clearance_value, scene_section
from forte.planning.tasks.schema import (
    Reader,
    check_joint_limits,
    controller_section,
    dataclass_from,
    robot_section,
)
from forte.planning.tasks.terms_section import settings_of, terms_section
from forte.planning.tasks.weights_section import read_weights
from forte.settings import CostWeights, KinematicLimits, SolverOptions, TermSettings, WeightSet
from forte.validation import MAX_FILE_BYTES, MAX_WAYPOINTS, FloatArray

MODES = ("trajectory", "hold")


@dataclass
class Task:
    """A validated planning problem.

    Attributes:
        t, targets: sample times (N) and world-frame end-effector poses (N x 4 x 4).
        payload: the payload the task force is computed for (unused with a force profile).
        force_profile: a force sequence given directly instead of a payload.
        targets_at, force_at: the path and the force profile as functions of time, so the task
            can be resampled (:meth:`resampled`) without re-reading its file.
        raw: the task's definition as read (recorded in plan.json).
        knots: ``(times, configurations)`` of a path given by taught whole-body configurations
            (``path.kind: taught``), else ``None``.
        controller: the task's ``controller:`` mapping for ``forte simulate`` (empty: the defaults
            of :mod:`forte.execution.gains`).
    """

    name: str
    source: Path | None
    robot: MobileManipulator
    mode: str
    t: FloatArray  # N
    targets: FloatArray  # N x 4 x 4 world-frame end-effector poses
    q_init: FloatArray
    radius: float
    payload: Payload
    force_profile: TaskForce | None  # a force given directly instead of a payload
    weights: CostWeights
    solver: SolverOptions
    teaching: FloatArray | None = None
    limits: KinematicLimits = field(default_factory=KinematicLimits)
    raw: dict[str, Any] = field(default_factory=dict)
    controller: dict[str, Any] = field(default_factory=dict)
    targets_at: TargetsAt | None = field(default=None, repr=False)
    force_at: ForceAt | None = field(default=None, repr=False)
    knots: tuple[FloatArray, FloatArray] | None = field(default=None, repr=False)

    #: The plan fails (exit 1) when the force ball leaves the RFP at some waypoint (d < 0).
    require_capacity: bool = False
    #: ``fixed``: ``r_k = radius``; ``mass-range``: the ball covers the mass estimate's range
    #: (:func:`forte.force.taskforce.mass_range_radius`, never below ``radius``; a mass given
    #: without a range keeps ``radius``).
    radius_rule: str = "fixed"
    #: ``paper``: ``(m + m_tool)(p'' - g)`` from t = 0; ``authors``: their lift's static
    #: ``(m + m_tool) g`` blended in over 1 s (a hold task: no blend), see :meth:`force`.
    force_model: str = "paper"
    #: Time of the ``authors`` blend already passed at ``t[0]`` (advanced by a horizon shift).
    force_ramp_elapsed: float = 0.0
    #: Static bodies around the robot and the floor (:mod:`forte.model.scene`; no bodies: free space).
    scene: Scene = field(default_factory=Scene)
    #: Distance (m) the plan keeps from every scene body and the floor (:data:`DEFAULT_CLEARANCE`).
    clearance: float = DEFAULT_CLEARANCE
    #: Cost terms the task adds to every optimized method, with their weight and settings
    #: (``terms:``, :mod:`forte.planning.tasks.terms_section`).
    terms: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: The cost terms' parameters (the weight set's with the task's own; :mod:`forte.planning.tasks.weights_section`).
    settings: TermSettings = field(default_factory=TermSettings)
    #: A contact-rich task (``contact:``, :mod:`forte.force.contact`): its model gives the force.
    contact: Contact | None = None
    #: The first waypoint's velocity and acceleration (a horizon spliced into a moving plan,
    #: :mod:`forte.planning.nlp.history`); ``None``: at rest, as a task file's.
    start_motion: StartMotion | None = None
    #: A goal task's goal (``path.kind: goal``, :mod:`forte.planning.tasks.goals`): its path is
    #: free and its targets are the forward kinematics of a motion (:meth:`following`).
    goal: Goal | None = None
    #: ``path.keep_level``: a tool axis kept near a world axis along the plan
    #: (:mod:`forte.planning.tasks.keep_level`); ``None``: no orientation constraint.
    keep_level: KeepLevel | None = None

    def with_weights(self, weight_set: WeightSet) -> Task:
        """The task with a named set's weights and term settings (the task's own ``terms:``
        settings kept on top)."""
        return replace(self, weights=weight_set.weights, settings=weight_set.settings.merged(settings_of(self.terms)))

    @property
    def n(self) -> int:
        return len(self.t)

    def nominal(self) -> FloatArray:
        """The task's nominal whole-body trajectory (N x nq).

        Taught configurations: their joint-space interpolation, one quintic per segment with
        zero velocity and acceleration at each knot (the authors' nominal trajectory, initial
        guess and "quintic" baseline); a hold task: its teaching configuration (else the IK
        solution); a path of poses: damped least-squares IK along it.
        """
        if self.knots is not None:  # held after the last knot (a final hold after the path's end)
            return quintic_path(self.knots[0], self.knots[1], np.minimum(self.t, self.knots[0][-1]))
        if self.mode == "hold" and self.teaching is not None:
            return self.teaching[None].copy()
        if self.goal is not None:  # the route to the goal, else the straight line
            return self.goal.motion(self.q_init, self.t)
        from forte.planning.tasks.ik import initial_guess

        return initial_guess(self)

    def resampled(self, n: int) -> Task:
        """The same task on ``n`` equally spaced samples of its time span (trajectory mode; a goal
        task: its targets along the straight line on the new samples)."""
        if self.goal is not None and 4 <= n <= MAX_WAYPOINTS:
            t = np.linspace(self.t[0], self.t[-1], n)
            goal = self.goal
            if goal.route is not None:  # the route on the new samples
                goal = replace(goal, route=np.column_stack([np.interp(t, self.t, c) for c in goal.route.T]))
            return replace(self, t=t, goal=goal, targets=goal_targets(self.robot, goal, goal.motion(self.q_init, t), t))
        if self.mode != "trajectory" or self.targets_at is None:
            raise TaskFileError(f"{self._where('path')}: only a trajectory task can be resampled")
        if n < 2 or n > MAX_WAYPOINTS:
            raise TaskFileError(f"waypoints: expected 2 to {MAX_WAYPOINTS} for a trajectory, got {n}")
        path, force_at = self.targets_at, self.force_at
        if isinstance(path, HeldPath):  # n samples of the path, the final hold decided again for them
            t, path = ending_at_rest(path.path, np.linspace(self.t[0], path.end, n))
            force_at = force_with_hold(force_at, path, t)
        else:
            t = np.linspace(self.t[0], self.t[-1], n)
        profile = force_at(t) if force_at is not None else None
        return replace(self, t=t, targets=path(t), targets_at=path, force_at=force_at, force_profile=profile)

    def following(self, q: FloatArray) -> Task:
        """A goal task with its targets the end-effector poses of the motion ``q`` (N x nq; the
        last one the goal pose of a pose goal), so :meth:`force` is the force along that motion
        (a plan's own, or its initial guess's). A task with a given path is returned unchanged:
        its force is its path's."""
        if self.goal is None:
            return self
        return replace(self, targets=goal_targets(self.robot, self.goal, q, self.t))

    def with_payload(self, payload: Payload) -> Task:
        """The same task carrying ``payload``."""
        return replace(self, payload=payload)

    def force(self, mass: float | None = None) -> TaskForce:
        """Desired forces: the given profile, the payload's force along the path, or both.

        The one owner of the task force. ``force_model: paper`` gives ``(m + m_tool) (p'' - g)``
        (:func:`~forte.force.taskforce.payload_force`); ``authors`` gives ``(m + m_tool) g`` up,
        blended in over :data:`~forte.force.taskforce.AUTHORS_FORCE_RAMP_S` on a trajectory and
        in full on a hold task (:func:`~forte.force.taskforce.authors_force`). ``m`` is the
        payload mass (``mass``, else given or estimated), ``m_tool`` the robot's
        ``tool_force_mass`` (the authors' end-effector load, 1.146 kg on the built-in robot).
        A task with a force profile uses the profile alone when it has no payload mass (the
        paper's Section 5.2), and the profile plus the payload's force (with its radii) when it
        has one: ``forte simulate`` carries that payload too. A payload with an offset centre of
        mass or an inertia adds its moment (:func:`~forte.force.wrench.with_payload_moment`).
        A pick-and-place task (``path.goals``) carries the payload from its grasp's waypoint on:
        before it the payload's share, its radius and its moment are zero
        (:func:`~forte.force.taskforce.attached_from`).
        """
        if self.contact is not None:
            return self._contact_force(mass)
        profile = self.force_profile
        m = mass if mass is not None else self.payload.mass
        if profile is not None and m is None:
            return profile
        if m is None:
            raise TaskFileError(
                f"{self._where('payload.mass')}: no payload mass; give payload.mass, --mass KG, "
                "or a payload description/image for the estimator"
            )
        total = m + self.robot.tool_force_mass
        if self.force_model == "authors":
            ramp = AUTHORS_FORCE_RAMP_S if self.mode == "trajectory" else 0.0
            force = authors_force(self.t, total, self.radius, self.robot.gravity, ramp, self.force_ramp_elapsed)
        else:
            force = payload_force(self.t, self.targets[:, :3, 3], total, self.radius, self.robot.gravity,
                                  self.ee_start())
        # the payload's own share (the tool load has no lever arm); an empty hand without a tool: none
        share = force.f * (m / total) if total > 0 else np.zeros_like(force.f)
        if profile is not None:
            force = TaskForce(self.t, profile.f + force.f, profile.r)
        elif self.radius_rule == "mass-range" and mass is None and self.payload.mass_range is not None:
            force = mass_range_radius(force, total, m, self.payload.mass_range, self.radius)
        force = with_payload_moment(force, self.payload, self.targets[:, :3, :3], share)
        grasp = None if self.goal is None else self.goal.grasp_step(self.t)
        return force if grasp is None else attached_from(force, share, grasp)

    def ee_start(self) -> StartMotion | None:
        """The end effector's start motion: its positions along ``start_motion``'s history."""
        if self.start_motion is None:
            return None
        return start_through(self.robot.ee_position, self.q_init, self.start_motion, float(self.t[1] - self.t[0]))

    def _contact_force(self, mass: float | None) -> TaskForce:
        """The contact model's force along the path (:func:`~forte.force.contact.contact_force`);
        ``mass`` replaces a carried object's mass (the verdict's payload bound)."""
        contact = self.contact
        if mass is not None and isinstance(contact, Carry):
            contact = replace(contact, mass=mass)
        tool = self.robot.tool_force_mass if isinstance(contact, Carry) else 0.0
        return contact_force(contact, self.t, self.targets, self.radius, tool, self.robot.gravity)

    def _where(self, key: str) -> str:
        return f"{self.source}: {key}" if self.source else key


def load_task(
    path: str | Path, mass: float | None = None, waypoints: int | None = None,
) -> Task:
    """Read and validate a task file.

    Args:
        path: The YAML file.
        mass: Payload mass overriding the file's (kg).
        waypoints: Number of samples overriding the file's (trajectory mode).

    Examples:
        From the repository root:

        >>> import forte
        >>> task = forte.load_task("examples/tasks/lift.yaml", waypoints=20)
        >>> task.n, task.payload.mass, task.resampled(30).n
        (20, 2.7, 30)
    """
    path = Path(path)
    return task_from_dict(read_yaml(path, "task file"), path, mass=mass, waypoints=waypoints)


def read_yaml(path: Path, what: str = "file") -> Any:
    """Parse a YAML file (UTF-8, at most :data:`MAX_FILE_BYTES`); every failure is one line."""
    try:
        if not path.is_file():
            raise TaskFileError(f"{path}: {what} does not exist")
        if path.stat().st_size > MAX_FILE_BYTES:
            raise TaskFileError(f"{path}: {path.stat().st_size} bytes; expected a {what} of at most "
                                f"{MAX_FILE_BYTES} bytes")
        raw = path.read_bytes()
    except OSError as exc:
        raise TaskFileError(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise TaskFileError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); "
                            "save the file as UTF-8") from None
    if "\0" in text:
        raise TaskFileError(f"{path}: contains a NUL character at offset {text.index(chr(0))}; expected YAML text")
    try:
        return yaml.safe_load(text)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        problem = " ".join(str(x) for x in (exc.context, exc.problem) if x) or "syntax error"
        raise TaskFileError(f"{path}: {where}not valid YAML: {problem}") from None
    except yaml.YAMLError as exc:
        raise TaskFileError(f"{path}: not valid YAML: {exc}") from None
    except RecursionError:
        raise TaskFileError(f"{path}: nested too deeply to be a {what}") from None


def task_from_dict(data: Any, path: Path | None = None, mass: float | None = None,
                   waypoints: int | None = None) -> Task:
    """Validate an already-parsed task (see :func:`load_task`)."""
    reader = Reader(dict(data) if isinstance(data, dict) else data, path)  # a copy: blocks are rewritten
    reader.unknown({"name", "robot", "mode", "initial_configuration", "path", "pose", "payload", "force",
                    "uncertainty_radius", "uncertainty_rule", "force_model", "weights", "torque_limits", "solver",
                    "teaching_configuration", "limits", "controller", "require_capacity", "scene", "scene_file",
                    "clearance", "terms", "contact", "floor"})
    base = path.parent if path else Path.cwd()
    robot = robot_section(reader, base)
    mode = reader.choice("mode", MODES, "trajectory")
    q_init, knots = start_configuration(reader, robot, mode)
    radius = reader.number("uncertainty_radius", DEFAULT_RADIUS, nonnegative=True, maximum=1e6, unit=" N")
    radius_rule = reader.choice("uncertainty_rule", RADIUS_RULES, "fixed")
    force_model = reader.choice("force_model", FORCE_MODELS, "paper")
    teaching = None
    if reader.has("teaching_configuration"):
        teaching = reader.vector("teaching_configuration", robot.nq)
        check_joint_limits(reader, "teaching_configuration", robot, teaching)
    limits = limits_section(reader, robot)
    goal_task = goal_section(reader, robot, mode, q_init, limits, waypoints)
    if goal_task is not None:
        (t, targets, goal), targets_at = goal_task, None
    else:
        t, targets, targets_at = path_targets(reader, robot, mode, robot.ee_pose(q_init), waypoints, teaching)
        goal = None
    contact, carried = read_contact(reader, targets, mode, mass)
    payload = payload_section(reader, base, mass) if contact is None else carried
    force_at = force_profile(reader, t, radius)
    if force_at is None and contact is None and (payload is None or payload.mass == 0):
        payload = payload or Payload(mass=0.0, source="none")  # an empty hand: the tool's load only
        radius = radius if reader.has("uncertainty_radius") else 0.0  # no payload: no uncertainty about it
    if goal is not None and goal.grasp is not None and (force_at is not None or contact is not None):
        raise reader.error("force" if force_at is not None else "contact",
                           "a pick-and-place task (path.goals) carries its payload from the grasp on; "
                           "give payload, not a force profile or a contact")
    if force_at is not None and reader.has("force_model"):
        raise reader.error("force_model", "sets a payload's force; this task gives its force profile directly")
    weights, settings = read_weights(reader, mode, robot)
    solver = dataclass_from(reader, "solver", SolverOptions,
                            SolverOptions() if goal is None else SolverOptions(max_iter=GOAL_MAX_ITER,
                                                                               time_budget_s=GOAL_SOLVE_BUDGET_S))
    if targets_at is not None and limits.end_at_rest:
        t, targets_at = ending_at_rest(targets_at, t)
        targets = targets_at(t)
        force_at = force_with_hold(force_at, targets_at, t)
    keep_level = keep_level_section(reader, robot, q_init, t, targets, goal) if mode == "trajectory" else None
    require_capacity = reader.get("require_capacity", False)
    if not isinstance(require_capacity, bool):
        raise reader.error("require_capacity", f"expected true or false, got {require_capacity!r}")
    name = str(reader.get("name", path.stem if path else "task"))
    scene, clearance = scene_section(reader, base, robot), clearance_value(reader)
    start_field = "initial_configuration" if reader.has("initial_configuration") else \
        "path.configurations[0].q" if knots is not None else "robot.home_arm"
    check_floor(reader, robot, q_init, scene, clearance, mode != "hold", start_field)
    return Task(name=name, source=path, robot=robot, mode=mode, t=t, targets=targets, q_init=q_init,
                radius=radius, payload=payload or Payload(source="none"),
                force_profile=None if force_at is None else force_at(t), weights=weights, settings=settings,
                solver=solver, teaching=teaching, limits=limits, raw=data, controller=controller_section(reader),
                targets_at=targets_at, force_at=force_at, require_capacity=require_capacity, knots=knots,
                radius_rule=radius_rule, force_model=force_model, scene=scene,
                clearance=clearance, terms=terms_section(reader), contact=contact, goal=goal,
                keep_level=keep_level)


