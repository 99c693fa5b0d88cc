"""ros2_controllers' JointTrajectoryController (Humble) for position command interfaces,
and the vendor hardware's streaming layers between its reference and the MuJoCo actuators.

Ported by reading ros2_controllers, branch `humble` (commit ad559d9c8054, 2025-08-11):
joint_trajectory_controller/src/joint_trajectory_controller.cpp and src/trajectory.cpp.
What this port keeps (file: function):

* Start state of a new trajectory -- joint_trajectory_controller.cpp: `update()`. On the first
  update() after a new message, before sampling it:
      if (params_.open_loop_control)
        traj_external_point_ptr_->set_point_before_trajectory_msg(time, last_commanded_state_, ...);
      else
        traj_external_point_ptr_->set_point_before_trajectory_msg(time, state_current_, ...);
  `state_current_` is read from the STATE interfaces (`read_state_from_state_interfaces()`)
  at the start of that same update(): so by default (open_loop_control: false, the
  parameter's default in joint_trajectory_controller_parameters.yaml) the trajectory starts
  from the MEASURED position, with the measured velocity only if a velocity state interface
  is configured (otherwise velocities are left empty, and trajectory.cpp:
  `set_point_before_trajectory_msg()` fills zeros when the first point has velocities).
  With open_loop_control: true it starts from `last_commanded_state_`, the last sampled
  reference (`last_commanded_state_ = state_desired_` after each write), including the
  velocity/acceleration of that sample. The vendor's ros2_controllers.yaml for RB-Y1
  (rby1_ros2, rby1_moveit_a_1_0) lists `state_interfaces: [position]` and sets neither
  open_loop_control nor allow_partial_joints_goal, so there it is: measured position, zero
  velocity, subsets of joints rejected.
* Activation -- `on_activate()`: with set_last_command_interface_value_as_state_on_activation
  (default true) and non-NaN command interfaces (rby1_hardware sets its commands to the
  measured positions on activate) state_current_ = last_commanded_state_ = the command
  interface values; then it holds position (`set_hold_position()`: one point = current
  positions, stamp 0).
* Message handling -- `topic_callback()` -> `validate_trajectory_msg()`: rejects (only logs)
  when: partial joints and !allow_partial_joints_goal; empty joint_names; empty points;
  header.stamp != 0 and stamp + last time_from_start < now; a joint name not among the
  controller's; (if !allow_nonzero_velocity_at_trajectory_end, default true on humble)
  nonzero last velocity; time_from_start not strictly increasing; positions size != names
  size; velocities/accelerations neither empty nor of names size; effort non-empty. A valid
  message REPLACES the current one (realtime buffer: only the latest before an update() is
  used). In update(): `fill_partial_goal()` (missing joints: position = current COMMAND
  interface value, velocity/acceleration 0) and `sort_to_local_joint_order()`.
* Timing -- trajectory.cpp: `Trajectory::sample()`: header.stamp == 0 means the trajectory
  starts at the time of its first sample (the next update() = "now"); otherwise at
  header.stamp. Before the first point's time it interpolates from the point-before
  (time of the first sample) to the first point; then between consecutive points; after
  the last point it returns the last point (velocities/accelerations resized to zeros):
  the controller HOLDS the last positions.
* Interpolation -- `interpolate_between_points()`: linear if either end lacks velocities,
  cubic (Hermite, position+velocity) if both have velocities but not both accelerations,
  quintic if both have velocities and accelerations. Outside [t_a, t_b] it clamps and
  falls back to linear. interpolation_method "none" forwards the next waypoint.
* Tolerances: all default to 0 (= not checked); goal_time 0; cmd_timeout 0: not emulated.

Deviations (documented, for the simulator's safety): non-finite numbers and duplicate joint
names are rejected (the JTC would pass them on). angle_wraparound is not emulated (RB-Y1's
joints are revolute with limits: the JTC sets it only for continuous joints).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

NS = 1_000_000_000


@dataclass
class Point:
    positions: np.ndarray
    velocities: Optional[np.ndarray] = None  # None = empty vector in the message
    accelerations: Optional[np.ndarray] = None
    effort: Optional[np.ndarray] = None
    tfs_ns: int = 0  # time_from_start

    def copy(self) -> "Point":
        c = lambda a: None if a is None else np.array(a, dtype=float)
        return Point(c(self.positions), c(self.velocities), c(self.accelerations), c(self.effort), self.tfs_ns)


@dataclass
class TrajectoryMsg:
    joint_names: List[str]
    points: List[Point]
    stamp_ns: int = 0


def _nonempty(a) -> Optional[np.ndarray]:
    return None if a is None or len(a) == 0 else np.asarray(a, dtype=float)


def make_msg(joint_names: Sequence[str], points: Sequence[dict], stamp_ns: int = 0) -> TrajectoryMsg:
    """Helper: points as dicts {positions, velocities?, accelerations?, effort?, t (s)}."""
    pts = []
    for p in points:
        pts.append(Point(np.asarray(p["positions"], dtype=float), _nonempty(p.get("velocities")),
                         _nonempty(p.get("accelerations")), _nonempty(p.get("effort")),
                         int(round(p["t"] * NS))))
    return TrajectoryMsg(list(joint_names), pts, stamp_ns)


def interpolate_between_points(time_a: int, a: Point, time_b: int, b: Point, sample_time: int) -> Point:
    """trajectory.cpp: Trajectory::interpolate_between_points (times in ns)."""
    so_far = (sample_time - time_a) / NS
    between = (time_b - time_a) / NS
    dim = len(a.positions)
    has_vel = a.velocities is not None and b.velocities is not None
    has_acc = a.accelerations is not None and b.accelerations is not None
    if so_far < 0.0:
        so_far = 0.0
        has_vel = has_acc = False
    if so_far > between:
        so_far = between
        has_vel = has_acc = False
    t = so_far
    out = Point(np.zeros(dim), np.zeros(dim), np.zeros(dim))
    p0, p1 = a.positions, b.positions
    if not has_vel and not has_acc:
        c1 = (p1 - p0) / between if between != 0.0 else np.zeros(dim)
        out.positions = p0 + t * c1
        out.velocities = c1.copy()
    elif has_vel and not has_acc:
        T = between
        v0, v1 = a.velocities, b.velocities
        c0, c1 = p0, v0
        if T != 0.0:
            c2 = (-3.0 * p0 + 3.0 * p1 - 2.0 * v0 * T - v1 * T) / (T * T)
            c3 = (2.0 * p0 - 2.0 * p1 + v0 * T + v1 * T) / (T * T * T)
        else:
            c2 = c3 = np.zeros(dim)
        out.positions = c0 + t * c1 + t * t * c2 + t ** 3 * c3
        out.velocities = c1 + 2.0 * t * c2 + 3.0 * t * t * c3
        out.accelerations = 2.0 * c2 + 6.0 * t * c3
    elif has_vel and has_acc:
        T = between
        v0, v1 = a.velocities, b.velocities
        a0, a1 = a.accelerations, b.accelerations
        c0, c1, c2 = p0, v0, 0.5 * a0
        if T != 0.0:
            T2, T3, T4, T5 = T ** 2, T ** 3, T ** 4, T ** 5
            c3 = (-20.0 * p0 + 20.0 * p1 - 3.0 * a0 * T2 + a1 * T2 - 12.0 * v0 * T - 8.0 * v1 * T) / (2.0 * T3)
            c4 = (30.0 * p0 - 30.0 * p1 + 3.0 * a0 * T2 - 2.0 * a1 * T2 + 16.0 * v0 * T + 14.0 * v1 * T) / (2.0 * T4)
            c5 = (-12.0 * p0 + 12.0 * p1 - a0 * T2 + a1 * T2 - 6.0 * v0 * T - 6.0 * v1 * T) / (2.0 * T5)
        else:
            c3 = c4 = c5 = np.zeros(dim)
        out.positions = c0 + t * c1 + t ** 2 * c2 + t ** 3 * c3 + t ** 4 * c4 + t ** 5 * c5
        out.velocities = c1 + 2.0 * t * c2 + 3.0 * t ** 2 * c3 + 4.0 * t ** 3 * c4 + 5.0 * t ** 4 * c5
        out.accelerations = 2.0 * c2 + 6.0 * t * c3 + 12.0 * t ** 2 * c4 + 20.0 * t ** 3 * c5
    return out


class Trajectory:
    """trajectory.cpp: Trajectory (positions always present: no deduce_from_derivatives)."""

    def __init__(self) -> None:
        self.msg: Optional[TrajectoryMsg] = None
        self.start_ns = 0
        self.time_before_ns = 0
        self.state_before: Optional[Point] = None
        self.sampled_already = False
        self.last_sample_idx = 0

    def update(self, msg: TrajectoryMsg) -> None:
        self.msg = msg
        self.start_ns = msg.stamp_ns
        self.sampled_already = False
        self.last_sample_idx = 0

    def set_point_before_trajectory_msg(self, now_ns: int, current: Point) -> None:
        self.time_before_ns = now_ns
        sb = current.copy()
        first = self.msg.points[0]
        if sb.velocities is None and first.velocities is not None:
            sb.velocities = np.zeros(len(first.velocities))
        if sb.accelerations is None and first.accelerations is not None:
            sb.accelerations = np.zeros(len(first.accelerations))
        self.state_before = sb

    def sample(self, t_ns: int, interpolate: bool = True) -> Tuple[bool, Optional[Point], int, int]:
        """(valid, output, start_segment_index, end_segment_index); end == len(points) past the end."""
        pts = self.msg.points
        if not pts:
            return False, None, len(pts), len(pts)
        if not self.sampled_already:
            if self.start_ns == 0:
                self.start_ns = t_ns
            self.sampled_already = True
        if t_ns < self.time_before_ns:
            return False, None, 0, 0
        first = pts[0]
        first_ts = self.start_ns + first.tfs_ns
        if t_ns < first_ts:
            if not interpolate:
                out = self.state_before.copy()
            else:
                out = interpolate_between_points(self.time_before_ns, self.state_before, first_ts, first, t_ns)
            return True, out, 0, 0
        last_idx = len(pts) - 1
        for i in range(self.last_sample_idx, last_idx):
            p, q = pts[i], pts[i + 1]
            t0 = self.start_ns + p.tfs_ns
            t1 = self.start_ns + q.tfs_ns
            if t0 <= t_ns < t1:
                if not interpolate:
                    out = q.copy()
                else:
                    out = interpolate_between_points(t0, p, t1, q, t_ns)
                out.tfs_ns = q.tfs_ns
                self.last_sample_idx = i
                return True, out, i, i + 1
        self.last_sample_idx = last_idx
        out = pts[last_idx].copy()
        dim = len(out.positions)
        if out.velocities is None:
            out.velocities = np.zeros(dim)
        if out.accelerations is None:
            out.accelerations = np.zeros(dim)
        return True, out, last_idx, len(pts)


class JointTrajectoryController:
    """The JTC's topic path with position command interfaces (no action server, no PIDs)."""

    def __init__(self, joints: Sequence[str], open_loop_control: bool = False,
                 allow_partial_joints_goal: bool = True, velocity_state: bool = False,
                 interpolation: str = "splines", allow_nonzero_velocity_at_trajectory_end: bool = True):
        self.joints = list(joints)
        self.index = {n: k for k, n in enumerate(self.joints)}
        self.dof = len(self.joints)
        self.open_loop_control = open_loop_control
        self.allow_partial_joints_goal = allow_partial_joints_goal
        self.velocity_state = velocity_state
        self.interpolate = interpolation == "splines"
        self.allow_nonzero_velocity_at_trajectory_end = allow_nonzero_velocity_at_trajectory_end
        self.command = np.full(self.dof, np.nan)  # the position command interfaces
        self.last_commanded: Optional[Point] = None
        self.traj = Trajectory()
        self.pending: Optional[TrajectoryMsg] = None  # realtime buffer: latest valid message
        self._pending_from_topic = False
        self.current_msg: Optional[TrajectoryMsg] = None
        self.superseded = 0  # valid messages replaced before any update() used them
        self.partial_messages = 0
        self.last_target: Optional[np.ndarray] = None  # last point of the latest applied message

    # -- lifecycle ------------------------------------------------------------------
    def activate(self, measured_q: np.ndarray, command_q: Optional[np.ndarray] = None) -> None:
        """on_activate(): command interfaces hold `command_q` (rby1_hardware: measured q)."""
        cq = np.array(measured_q if command_q is None else command_q, dtype=float)
        self.command = cq.copy()
        # read_state_from_command_interfaces: positions from the command interfaces; with a
        # velocity state interface but no velocity command interface it fails -> state ifs.
        if self.velocity_state:
            self.last_commanded = Point(np.array(measured_q, dtype=float), np.zeros(self.dof))
        else:
            self.last_commanded = Point(cq.copy())
        self.hold(self.last_commanded.positions)

    def hold(self, q: np.ndarray) -> None:
        """set_hold_position(): one point at q, stamp 0, applied at the next update()."""
        self.pending = TrajectoryMsg(list(self.joints), [Point(np.array(q, dtype=float))], 0)
        self._pending_from_topic = False

    # -- input ------------------------------------------------------------------------
    def validate(self, msg: TrajectoryMsg, now_ns: int) -> Optional[str]:
        """validate_trajectory_msg(): None if valid, else the reason."""
        n = len(msg.joint_names)
        if not self.allow_partial_joints_goal and n != self.dof:
            return "partial joints goal not allowed"
        if n == 0:
            return "empty joint names"
        if not msg.points:
            return "empty trajectory"
        if msg.stamp_ns != 0 and msg.stamp_ns + msg.points[-1].tfs_ns < now_ns:
            return "non-zero start time and ends in the past"
        for name in msg.joint_names:
            if name not in self.index:
                return f"unknown joint {name}"
        if len(set(msg.joint_names)) != n:  # deviation: the JTC does not check this
            return "duplicate joint names"
        if not self.allow_nonzero_velocity_at_trajectory_end:
            v = msg.points[-1].velocities
            if v is not None and np.any(np.abs(v) > np.finfo(np.float32).eps):
                return "nonzero velocity at trajectory end"
        prev = 0
        for i, p in enumerate(msg.points):
            if i > 0 and p.tfs_ns <= prev:
                return "time_from_start not strictly increasing"
            prev = p.tfs_ns
            if p.positions is None or len(p.positions) != n:
                return "positions size mismatch"
            if p.velocities is not None and len(p.velocities) != n:
                return "velocities size mismatch"
            if p.accelerations is not None and len(p.accelerations) != n:
                return "accelerations size mismatch"
            if p.effort is not None:
                return "effort not supported"
            for arr in (p.positions, p.velocities, p.accelerations):  # deviation: finite only
                if arr is not None and not np.all(np.isfinite(arr)):
                    return "non-finite value"
        return None

    def submit(self, msg: TrajectoryMsg, now_ns: int) -> Optional[str]:
        """topic_callback(): None if accepted (replaces any pending one), else the reason."""
        why = self.validate(msg, now_ns)
        if why is not None:
            return why
        if len(msg.joint_names) != self.dof:
            self.partial_messages += 1
        if self.pending is not None and self._pending_from_topic:
            self.superseded += 1
        self.pending = msg
        self._pending_from_topic = True
        return None

    def forward(self, q: np.ndarray) -> None:
        """A forward position command (another controller writing the command interfaces):
        the running trajectory is dropped and the command interfaces take q."""
        self.pending = None
        self.traj = Trajectory()
        self.current_msg = None
        self.command = np.array(q, dtype=float)
        self.last_commanded = Point(self.command.copy())

    def reset(self, q: np.ndarray) -> None:
        """Simulation reset: drop everything, command = last commanded = q, hold q."""
        self.traj = Trajectory()
        self.current_msg = None
        self.command = np.array(q, dtype=float)
        self.last_commanded = Point(self.command.copy())
        self.hold(q)

    # -- cycle --------------------------------------------------------------------------
    def _fill_and_sort(self, msg: TrajectoryMsg) -> TrajectoryMsg:
        """fill_partial_goal() + sort_to_local_joint_order() into a new message."""
        names = list(msg.joint_names)
        pts = [p.copy() for p in msg.points]
        if len(names) != self.dof:
            for k, jn in enumerate(self.joints):
                if jn in names:
                    continue
                names.append(jn)
                fill = self.command[k]  # last command if not NaN, else the state (not reached here)
                for p in pts:
                    p.positions = np.append(p.positions, fill)
                    if p.velocities is not None:
                        p.velocities = np.append(p.velocities, 0.0)
                    if p.accelerations is not None:
                        p.accelerations = np.append(p.accelerations, 0.0)
        order = np.array([self.index[n] for n in names])
        for p in pts:
            for attr in ("positions", "velocities", "accelerations"):
                a = getattr(p, attr)
                if a is not None:
                    o = np.zeros(self.dof)
                    o[order] = a
                    setattr(p, attr, o)
        return TrajectoryMsg(list(self.joints), pts, msg.stamp_ns)

    def update(self, now_ns: int, measured_q: np.ndarray, measured_v: Optional[np.ndarray] = None) -> np.ndarray:
        """One update(): returns the position command interface values."""
        if self.pending is not None:
            msg = self._fill_and_sort(self.pending)
            self.current_msg = self.pending
            self.pending = None
            self.traj.update(msg)
            self.last_target = msg.points[-1].positions.copy()
        if self.traj.msg is None:
            return self.command
        state_current = Point(np.array(measured_q, dtype=float),
                              np.array(measured_v, dtype=float) if (self.velocity_state and measured_v is not None) else None)
        if not self.traj.sampled_already:
            if self.open_loop_control:
                self.traj.set_point_before_trajectory_msg(now_ns, self.last_commanded)
            else:
                self.traj.set_point_before_trajectory_msg(now_ns, state_current)
        valid, out, _, _ = self.traj.sample(now_ns, self.interpolate)
        if valid:
            self.command = out.positions.copy()
            self.last_commanded = out
        return self.command


# ------------------------------------------------------------------------------------------
# The vendor hardware's streaming layers
# ------------------------------------------------------------------------------------------


class HwFollower:
    """rby1_hardware streams each new reference to the robot as a joint position command
    (minimum time `min_time`, velocity limit `vmax`, acceleration limit `amax`); the robot
    moves toward the newest target time-optimally under those limits. Emulated per joint and
    per physics step as a second-order follower: the velocity is steered toward
        sign(d) * min(vmax, v_brake(|d|), |d| / max(min_time, dt)),   d = target - p,
    with the velocity changing by at most amax*dt per step. v_brake is the largest speed
    from which the discrete deceleration at amax (this step included) stops within |d| (no
    overshoot toward a fixed target, time-optimal to the step); the |d|/min_time term makes
    the last approach take at least ~min_time.
    amax <= 0 disables the layer (p = target)."""

    def __init__(self, n: int, vmax: float, amax: float, min_time: float, dt: float):
        self.n, self.vmax, self.amax, self.min_time, self.dt = n, vmax, amax, min_time, dt
        self.enabled = amax > 0.0 and vmax > 0.0
        self.p = np.zeros(n)
        self.v = np.zeros(n)
        self._k = 8.0 / (amax * dt * dt) if self.enabled else 0.0
        self._tau = max(min_time, dt)

    def reset(self, q: np.ndarray) -> None:
        self.p[:] = q
        self.v[:] = 0.0

    def step(self, target: np.ndarray) -> np.ndarray:
        if not self.enabled:
            self.p[:] = target
            self.v[:] = 0.0
            return self.p
        d = target - self.p
        if not self.v.any() and not d.any():  # at rest on the target
            return self.p
        ad = np.abs(d)
        # largest speed v with v*dt + (min. braking distance from v at amax, per step) <= |d|:
        # m = whole braking steps, v_b = |d| / (dt (m+1)) + amax dt m / 2
        m = np.floor(0.5 * (np.sqrt(1.0 + self._k * ad) - 1.0))
        vb = ad / (self.dt * (m + 1.0)) + (0.5 * self.amax * self.dt) * m
        vdes = np.minimum(np.minimum(vb, ad / self._tau), self.vmax)
        vdes *= np.sign(d)
        adt = self.amax * self.dt
        v_old = self.v
        v = v_old + np.clip(vdes - v_old, -adt, adt)
        np.clip(v, -self.vmax, self.vmax, out=v)
        # do not step past a target that can be reached exactly within the acceleration limit
        exact = d / self.dt
        past = (v * d > 0.0) & (np.abs(v) > np.abs(exact)) & (np.abs(exact - v_old) <= adt)
        if past.any():
            v = np.where(past, exact, v)
        self.v = v
        self.p += v * self.dt
        return self.p


class TargetFilter:
    """The firmware's first-order low-pass on the position target (cut-off f Hz, per step):
    y += alpha * (x - y), alpha = 1 - exp(-2 pi f dt). f <= 0 disables it (y = x)."""

    def __init__(self, n: int, f_hz: float, dt: float):
        self.enabled = f_hz > 0.0
        self.alpha = 1.0 - math.exp(-2.0 * math.pi * f_hz * dt) if self.enabled else 1.0
        self.y = np.zeros(n)

    def reset(self, q: np.ndarray) -> None:
        self.y[:] = q

    def step(self, x: np.ndarray) -> np.ndarray:
        if self.enabled:
            self.y += self.alpha * (x - self.y)
        else:
            self.y[:] = x
        return self.y
