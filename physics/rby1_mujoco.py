#!/usr/bin/env python3
"""Physics-simulated Rainbow Robotics RB-Y1 (dual arm) speaking ROS 2 over DDS.

MuJoCo (official Python binding, 3.3.x) simulates the vendor's own MuJoCo model of the
robot (rby1-sdk `models/rby1a/mujoco`: bodies, inertias, joint armature/damping, position
actuators kp 4000 / kv 400, timestep 0.002 s), welded to the world, meshes dropped, no
contacts (see rby1_model.py). An independent Eclipse Cyclone DDS peer (PyPI `cyclonedds`),
like the vendor's driver, which shares no code with the crossym node's DDS stack.

    python3 physics/rby1_mujoco.py --model-dir SDK/mujoco [--version 1.0] [--urdf URDF]
        [--joints a,b,...] [--initial-q v,...] [--domain N] [--rate-hz 100] [--summary OUT]
        [--open-loop-control] [--gravity-compensation] [--no-force-limits]
        [--hw-velocity 4.712] [--hw-acceleration 1.0] [--hw-min-time 0.01] [--no-hw-limits]
        [--target-filter-hz 15] [--freeze-joint NAME --freeze-after-s T] [--hold-after-s T]

Topics (ROS names; on DDS `rt/<name>`, types `<pkg>::msg::dds_::<T>_`, XCDR1):
  publishes  /joint_states                         sensor_msgs/JointState   every hinge/slide joint,
             at --rate-hz, wall-clock stamps, reliable, volatile, keep last 10
  subscribes /both_arms_controller/joint_trajectory trajectory_msgs/JointTrajectory (reliable, keep last 10)
  subscribes /position_controller/commands          std_msgs/Float64MultiArray (forward position
             command in --joints order; legacy)
  subscribes /mock_hw/reset                          std_msgs/Float64MultiArray (simulation-only
             teleport of the controlled joints; commands within 0.05 s after it are discarded)

The command path, per controlled joint (each stage can be switched off):

 1. JointTrajectoryController (ros2_controllers, Humble), ported in jtc.py, run at
    --controller-rate-hz (100, the vendor's controller_manager update_rate). Its output is
    "the reference" (position command interface). By default a new trajectory starts from
    the MEASURED position (open_loop_control false); --open-loop-control starts it from the
    last commanded reference. header.stamp 0 = start now; linear / cubic / quintic splines
    by the fields present; after the last point it holds the last positions.
 2. rby1_hardware's streaming (--hw-velocity 4.712 rad/s, --hw-acceleration 1.0 rad/s^2,
    --hw-min-time 0.01 s): the hardware interface streams each new reference to the robot
    as a joint position command with a minimum time under velocity/acceleration limits;
    the robot moves to the newest target time-optimally. Emulated per physics step by a
    second-order follower (velocity <= vmax, |acceleration| <= amax, braking so it does not
    overshoot a fixed target, last approach no faster than min_time). The values are the
    vendor's rby1_hardware defaults (4.712 rad/s = 270 deg/s, 1.0 rad/s^2, minimum time
    0.01 s). Cross-check in the public RainbowRobotics/rby1_ros2 sources: 4.712388 and 1.0
    are the max_velocity / max_acceleration of its MoveIt joint_limits guide and
    SetMinimumTime(0.01) its streaming example; the stored rby1_system_hardware.cpp
    revisions send JointPositionCommandBuilder().SetPosition(q) (SDK-side defaults), an
    older rby1-ros2 one SetMinimumTime(0.03). --hw-acceleration 0 or --no-hw-limits
    disables the layer.
 3. The firmware's first-order low-pass on the position target (15 Hz: the firmware's
    target filter), --target-filter-hz 15 (0 disables), per physics step; its output is
    the MuJoCo position actuator's ctrl.
 4. MuJoCo position actuator (kp 4000, kv 400; ctrl clamped to the vendor's ctrlrange),
    force-limited to +-URDF <limit effort> (70/70/70/40/10/10/8 N m on the arms) unless
    --no-force-limits; --gravity-compensation adds MuJoCo's passive gravity compensation
    on every body (as the vendor's controller may do). Without it the arms sag by a few
    mrad (gravity torque / kp).

Faults for tests: --freeze-joint NAME --freeze-after-s T locks that joint from T (wall
seconds since start) where it is ("robot stops following"); --hold-after-s T emulates
rby1_hardware's collision hold: from T the hardware holds the measured position of that
moment and ignores every command (the controller still runs and still accepts commands).

Pacing: physics steps of the model's timestep, paced against time.monotonic(); when the loop
falls behind it steps to catch up (at most 0.1 s of simulated time per iteration, counted as
late_iterations); the integration never uses a wall-clock dt. The controller's clock is
wall-clock time at start + simulated time (rebased if the simulation had to drop time).

--summary OUT writes JSON on exit (SIGTERM / SIGINT / --duration): steps,
commands_received, commands_dropped, commands_discarded, commands_invalid,
joint_states_published, resets, violation_count, violations, max_abs_velocity,
last_command, fault_started_s, fault_trigger_joint, joint_states_faulted, tracking_error,
torque_limit_time_s, min_limit_margin, late_iterations, ... (see Summary keys in README.md).
"""
# No `from __future__ import annotations`: ros_types' cyclonedds types resolve by name.

import argparse
import json
import math
import os
import signal
import sys
import time
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
import mujoco

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from jtc import NS, HwFollower, JointTrajectoryController, Point, TargetFilter, TrajectoryMsg  # noqa: E402
from rby1_model import DEFAULT_JOINTS, VERSIONS, UrdfJoint, default_urdf, load_model, read_urdf  # noqa: E402

POS_TOL = 1e-6  # rad
VEL_TOL = 1e-6  # rad/s
RESET_QUIET_S = 0.05  # commands arriving this soon after a reset are discarded
MAX_CATCHUP_S = 0.1
MAX_VIOLATIONS_LISTED = 100


class ErrorHistogram:
    """p50/p99/max of |reference - measured| per joint without storing samples:
    log-spaced bins from 1e-9 rad to 10 rad (2.3 % relative width); a percentile is the
    upper edge of its bin, capped at the exact maximum."""

    def __init__(self, n: int, lo: float = 1e-9, hi: float = 10.0, bins: int = 1000):
        self.edges = np.logspace(math.log10(lo), math.log10(hi), bins + 1)
        self.nb = bins + 2
        self.counts = np.zeros(n * self.nb, dtype=np.int64)
        self.rows = np.arange(n) * self.nb
        self.max = np.zeros(n)
        self.n = n
        self.samples = 0

    def add(self, err: np.ndarray) -> None:
        idx = np.searchsorted(self.edges, err)
        self.counts[self.rows + idx] += 1
        np.maximum(self.max, err, out=self.max)
        self.samples += 1

    def percentile(self, k: int, p: float) -> float:
        c = self.counts[k * self.nb:(k + 1) * self.nb]
        total = int(c.sum())
        if total == 0:
            return 0.0
        b = int(np.searchsorted(np.cumsum(c), math.ceil(p * total)))
        if b == 0:
            return 0.0 if self.max[k] == 0.0 else float(min(self.edges[0], self.max[k]))
        edge = self.edges[min(b, len(self.edges) - 1)]
        return float(min(edge, self.max[k]))


class Rby1Sim:
    """The simulated robot without DDS: MuJoCo + JTC + hardware layers + bookkeeping."""

    def __init__(self, model: mujoco.MjModel, joints: Sequence[str], initial_q: Optional[Sequence[float]],
                 urdf_joints: Dict[str, UrdfJoint], *, hw_velocity: float = 4.712, hw_acceleration: float = 1.0,
                 hw_min_time: float = 0.01, target_filter_hz: float = 15.0, controller_rate_hz: float = 100.0,
                 open_loop_control: bool = False, allow_partial_joints_goal: bool = True,
                 velocity_state: bool = False, interpolation: str = "splines", clock_origin_ns: int = 0,
                 position_limits: Optional[Sequence[Tuple[float, float]]] = None):
        self.m = model
        self.d = mujoco.MjData(model)
        m, d = self.m, self.d
        self.dt = float(m.opt.timestep)
        self.dt_ns = int(round(self.dt * NS))
        self.k = 0  # physics steps done
        self.clock_origin_ns = int(clock_origin_ns)
        self.ctrl_every = max(1, int(round(1.0 / (controller_rate_hz * self.dt))))

        # every hinge/slide joint, published in model order
        self.pub_ids = [j for j in range(m.njnt) if m.jnt_type[j] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)]
        self.pub_names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in self.pub_ids]
        self.pub_qadr = np.array([m.jnt_qposadr[j] for j in self.pub_ids])
        self.pub_dadr = np.array([m.jnt_dofadr[j] for j in self.pub_ids])

        # actuators by joint
        act_of: Dict[str, int] = {}
        self.act_kind: Dict[int, str] = {}
        for a in range(m.nu):
            if m.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
                continue
            jn = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, m.actuator_trnid[a, 0])
            act_of[jn] = a
            if m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE and m.actuator_biasprm[a, 1] < 0:
                self.act_kind[a] = "position"
            elif m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE and m.actuator_biasprm[a, 2] < 0:
                self.act_kind[a] = "velocity"
            else:
                self.act_kind[a] = "motor"

        self.joints = list(joints)
        n = self.n = len(self.joints)
        jid = []
        for name in self.joints:
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
            if j < 0:
                raise ValueError(f"controlled joint {name!r} is not in the model")
            if name not in act_of or self.act_kind[act_of[name]] != "position":
                raise ValueError(f"controlled joint {name!r} has no position actuator")
            jid.append(j)
        if len(set(self.joints)) != n:
            raise ValueError("duplicate controlled joints")
        self.qadr = np.array([m.jnt_qposadr[j] for j in jid])
        self.dadr = np.array([m.jnt_dofadr[j] for j in jid])
        self.act_idx = np.array([act_of[nm] for nm in self.joints])
        q0 = np.zeros(n) if initial_q is None else np.array(initial_q, dtype=float)
        if q0.shape != (n,):
            raise ValueError(f"--initial-q has {q0.size} values, {n} controlled joints")

        # URDF limits of the controlled joints
        inf = math.inf
        self.lower = np.array([urdf_joints[nm].lower if nm in urdf_joints else -inf for nm in self.joints])
        self.upper = np.array([urdf_joints[nm].upper if nm in urdf_joints else inf for nm in self.joints])
        if position_limits is not None:
            # the node's limits (its config may narrow a joint): checked where tighter
            if len(position_limits) != n:
                raise ValueError(f"--position-limits has {len(position_limits)} pairs, {n} controlled joints")
            self.lower = np.maximum(self.lower, [lo for lo, _ in position_limits])
            self.upper = np.minimum(self.upper, [hi for _, hi in position_limits])
        self.vlim = np.array([urdf_joints[nm].velocity if nm in urdf_joints else inf for nm in self.joints])
        self.lo_tol = self.lower - POS_TOL
        self.hi_tol = self.upper + POS_TOL
        self.vlim_tol = self.vlim + VEL_TOL
        frc = np.array([m.actuator_forcerange[a, 1] if m.actuator_forcelimited[a] else inf for a in self.act_idx])
        self.force_limited = bool(np.any(np.isfinite(frc)))
        self.force_thr = 0.999 * frc

        # initial state: controlled joints at q0, everything else 0, position actuators hold
        d.qpos[:] = 0.0
        d.qpos[self.qadr] = q0
        d.qvel[:] = 0.0
        d.ctrl[:] = 0.0
        d.ctrl[self.act_idx] = q0
        mujoco.mj_forward(m, d)

        self.jtc = JointTrajectoryController(self.joints, open_loop_control, allow_partial_joints_goal,
                                             velocity_state, interpolation)
        self.jtc.activate(q0)
        self.follower = HwFollower(n, hw_velocity, hw_acceleration, hw_min_time, self.dt)
        self.follower.reset(q0)
        self.filter = TargetFilter(n, target_filter_hz, self.dt)
        self.filter.reset(q0)
        self.reference = q0.copy()
        self.hold_q: Optional[np.ndarray] = None
        self.freeze: Optional[tuple] = None  # (qadr, dofadr, value)
        self.fault_started_s: Optional[float] = None
        self.fault_started_wall_s: Optional[float] = None
        self.fault_kind: Optional[str] = None
        self.fault_joint: Optional[str] = None
        self.released_s: Optional[float] = None  # simulated time of the last lock/hold release

        # bookkeeping
        self.violation_count = 0
        self.position_violations = 0
        self.velocity_violations = 0
        self.violations: List[dict] = []
        self.max_abs_velocity = np.zeros(n)
        self.min_margin = np.full(n, inf)
        self.torque_time = np.zeros(n)
        self.torque_run = np.zeros(n)  # current continuous time at the torque limit
        self.torque_run_after_release = np.zeros(n)  # its longest since a release
        self.hist = ErrorHistogram(n)
        self.resets = 0
        self._tmp = np.zeros(n)

    # -- time ---------------------------------------------------------------------------
    @property
    def sim_time(self) -> float:
        return self.k * self.dt

    def clock_ns(self) -> int:
        """The controller's clock: origin + simulated time."""
        return self.clock_origin_ns + self.k * self.dt_ns

    # -- inputs -------------------------------------------------------------------------
    def submit_trajectory(self, msg: TrajectoryMsg) -> Optional[str]:
        return self.jtc.submit(msg, self.clock_ns())

    def submit_forward(self, data: Sequence[float]) -> Optional[str]:
        a = np.asarray(data, dtype=float)
        if a.shape != (self.n,):
            return f"size {a.size} != {self.n}"
        if not np.all(np.isfinite(a)):
            return "non-finite value"
        self.jtc.forward(a)
        self.reference = self.jtc.command.copy()
        return None

    def reset(self, q: Sequence[float]) -> Optional[str]:
        a = np.asarray(q, dtype=float)
        if a.shape != (self.n,):
            return f"size {a.size} != {self.n}"
        if not np.all(np.isfinite(a)):
            return "non-finite value"
        d = self.d
        d.qpos[self.qadr] = a
        d.qvel[:] = 0.0
        d.qacc_warmstart[:] = 0.0
        self.jtc.reset(a)
        self.reference = a.copy()
        self.follower.reset(a)
        self.filter.reset(a)
        d.ctrl[self.act_idx] = a
        if self.hold_q is not None:
            self.hold_q = a.copy()
        mujoco.mj_forward(self.m, d)
        self.resets += 1
        return None

    # -- faults -------------------------------------------------------------------------
    def start_freeze(self, joint: str, wall_s: float) -> None:
        j = mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_JOINT, joint)
        if j < 0:
            raise ValueError(f"--freeze-joint {joint!r} is not in the model")
        qa, da = self.m.jnt_qposadr[j], self.m.jnt_dofadr[j]
        self.freeze = (qa, da, float(self.d.qpos[qa]))
        self.d.qvel[da] = 0.0
        self._fault("freeze", joint, wall_s)

    def start_hold(self, wall_s: float) -> None:
        # The hardware holds the measured position of this moment at once (its own stop,
        # not the streaming layer's acceleration limit): the streaming target jumps there.
        self.hold_q = self.d.qpos[self.qadr].copy()
        self.follower.reset(self.hold_q)
        self._fault("hold", None, wall_s)

    def end_freeze(self) -> None:
        """The lock releases: the joint is free again (its actuator pulls it to its target)."""
        self.freeze = None
        self.released_s = self.sim_time

    def end_hold(self) -> None:
        """The collision hold releases: the streaming layer resumes from the held position at
        rest toward the controller's reference."""
        self.hold_q = None
        self.released_s = self.sim_time

    def _fault(self, kind, joint, wall_s):
        if self.fault_started_s is None:
            self.fault_started_s = round(self.sim_time, 6)  # simulated time (= wall time when on pace)
            self.fault_started_wall_s = float(wall_s)
            self.fault_kind = kind
            self.fault_joint = joint
        else:
            self.fault_kind += "+" + kind

    # -- stepping -----------------------------------------------------------------------
    def controller_tick(self) -> None:
        d = self.d
        q = d.qpos[self.qadr]
        v = d.qvel[self.dadr]
        self.reference = self.jtc.update(self.clock_ns(), q, v).copy()

    def step(self) -> None:
        d = self.d
        if self.k % self.ctrl_every == 0:
            self.controller_tick()
        target = self.reference if self.hold_q is None else self.hold_q
        p = self.follower.step(target)
        y = self.filter.step(p)
        d.ctrl[self.act_idx] = y
        mujoco.mj_step(self.m, d)
        self.k += 1
        if self.freeze is not None:
            qa, da, val = self.freeze
            d.qpos[qa] = val
            d.qvel[da] = 0.0
        self._check()

    def run(self, steps: int) -> None:
        for _ in range(steps):
            self.step()

    def _check(self) -> None:
        d = self.d
        q = d.qpos[self.qadr]
        v = d.qvel[self.dadr]
        lo = q < self.lo_tol
        hi = q > self.hi_tol
        if lo.any() or hi.any():
            for k in np.nonzero(lo | hi)[0]:
                self._violation(k, "position", float(q[k]), float(self.lower[k] if lo[k] else self.upper[k]))
        tmp = self._tmp
        np.subtract(q, self.lower, out=tmp)
        np.minimum(self.min_margin, tmp, out=self.min_margin)
        np.subtract(self.upper, q, out=tmp)
        np.minimum(self.min_margin, tmp, out=self.min_margin)
        av = np.abs(v)
        np.maximum(self.max_abs_velocity, av, out=self.max_abs_velocity)
        vv = av > self.vlim_tol
        if vv.any():
            for k in np.nonzero(vv)[0]:
                self._violation(k, "velocity", float(v[k]), float(math.copysign(self.vlim[k], v[k])))
        np.subtract(self.reference, q, out=tmp)
        np.abs(tmp, out=tmp)
        self.hist.add(tmp)
        if self.force_limited:
            af = np.abs(d.actuator_force[self.act_idx])
            at = af >= self.force_thr
            self.torque_time += at * self.dt
            self.torque_run = np.where(at, self.torque_run + self.dt, 0.0)
            if self.released_s is not None:
                # Only the part of a run after the release (a locked joint's actuator pushes
                # at its limit while the lock lasts: that is the lock, not the release).
                after = np.minimum(self.torque_run, self.sim_time - self.released_s)
                np.maximum(self.torque_run_after_release, after, out=self.torque_run_after_release)

    def _violation(self, k, kind, value, bound):
        self.violation_count += 1
        if kind == "position":
            self.position_violations += 1
        else:
            self.velocity_violations += 1
        if len(self.violations) < MAX_VIOLATIONS_LISTED:
            self.violations.append({"time_s": round(self.sim_time, 6), "joint": self.joints[k], "kind": kind,
                                    "value": value, "bound": bound})

    # -- outputs ------------------------------------------------------------------------
    def joint_state_arrays(self):
        d = self.d
        return (d.qpos[self.pub_qadr].tolist(), d.qvel[self.pub_dadr].tolist(),
                d.qfrc_actuator[self.pub_dadr].tolist())

    def measured(self) -> np.ndarray:
        return self.d.qpos[self.qadr].copy()

    def report(self) -> dict:
        n = self.n
        te = {self.joints[k]: {"p50": self.hist.percentile(k, 0.50), "p99": self.hist.percentile(k, 0.99),
                               "max": float(self.hist.max[k])} for k in range(n)}
        return {
            "steps": self.k,
            "sim_time_s": round(self.sim_time, 6),
            "resets": self.resets,
            "violation_count": self.violation_count,
            "position_violations": self.position_violations,
            "velocity_violations": self.velocity_violations,
            "violations": self.violations,
            "max_abs_velocity": {self.joints[k]: float(self.max_abs_velocity[k]) for k in range(n)},
            "tracking_error": te,
            "torque_limit_time_s": {self.joints[k]: round(float(self.torque_time[k]), 6) for k in range(n)},
            "torque_limit_run_after_release_s": {self.joints[k]: round(float(self.torque_run_after_release[k]), 6)
                                                 for k in range(n)},
            "released_s": self.released_s,
            "min_limit_margin": {self.joints[k]: float(self.min_margin[k]) for k in range(n)},
            "fault_started_s": self.fault_started_s,
            "fault_started_wall_s": self.fault_started_wall_s,
            "fault_kind": self.fault_kind,
            "fault_joint": self.fault_joint,
            "final_position": {self.joints[k]: float(v) for k, v in enumerate(self.d.qpos[self.qadr])},
            "last_reference": self.reference.tolist(),
            "trajectories_superseded": self.jtc.superseded,
            "partial_trajectories": self.jtc.partial_messages,
        }


def parse_floats(s: str) -> List[float]:
    return [float(x) for x in s.split(",") if x.strip()]


def build_sim(args, clock_origin_ns: int = 0):
    """Model + Rby1Sim from parsed CLI args; returns (sim, build_info, urdf_path)."""
    urdf = args.urdf or default_urdf(args.model_dir, args.version)
    model, info = load_model(args.model_dir, args.version, urdf, not args.no_force_limits,
                             args.gravity_compensation)
    urdf_joints = read_urdf(urdf) if urdf else {}
    joints = [s for s in args.joints.split(",") if s] if args.joints else list(DEFAULT_JOINTS)
    q0 = parse_floats(args.initial_q) if args.initial_q else None
    limits = None
    if args.position_limits:
        limits = []
        for pair in args.position_limits.split(","):
            lo, hi = pair.split(":")
            limits.append((float(lo), float(hi)))
    hw_a = 0.0 if args.no_hw_limits else args.hw_acceleration
    sim = Rby1Sim(model, joints, q0, urdf_joints, hw_velocity=args.hw_velocity, hw_acceleration=hw_a,
                  hw_min_time=args.hw_min_time, target_filter_hz=args.target_filter_hz,
                  controller_rate_hz=args.controller_rate_hz, open_loop_control=args.open_loop_control,
                  allow_partial_joints_goal=not args.no_partial_joints_goal,
                  velocity_state=args.jtc_velocity_state, interpolation=args.interpolation,
                  clock_origin_ns=clock_origin_ns, position_limits=limits)
    return sim, info, urdf


def make_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model-dir", required=True, help="the SDK's mujoco/ folder (model_act.xml, rby1_v*.xml, assets/)")
    ap.add_argument("--version", choices=VERSIONS, default="1.0", help="robot version (body file rby1_v<version>.xml)")
    ap.add_argument("--urdf", help="URDF for force limits and the limit checks (default: ../urdf/model_v<version>.urdf)")
    ap.add_argument("--no-force-limits", action="store_true", help="no actuator force limits")
    ap.add_argument("--gravity-compensation", action="store_true", help="MuJoCo gravcomp=1 on every body")
    ap.add_argument("--joints", help="controlled joints in command order, comma-separated "
                    "(default: left_arm_0..6,right_arm_0..6)")
    ap.add_argument("--initial-q", help="initial positions of the controlled joints (rad), comma-separated (default 0)")
    ap.add_argument("--position-limits", help="lower:upper per controlled joint (rad), comma-separated: checked "
                    "where tighter than the URDF's (the node's [robot] limits)")
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0") or 0))
    ap.add_argument("--rate-hz", type=float, default=100.0, help="joint_states rate and loop rate (Hz)")
    ap.add_argument("--controller-rate-hz", type=float, default=100.0, help="JTC update rate (Hz, vendor: 100)")
    ap.add_argument("--open-loop-control", action="store_true",
                    help="JTC open_loop_control: new trajectories start from the last reference (default: measured)")
    ap.add_argument("--no-partial-joints-goal", action="store_true",
                    help="JTC allow_partial_joints_goal false (the JTC's own default; the vendor's config "
                    "keeps it): reject trajectories naming a subset of the joints")
    ap.add_argument("--jtc-velocity-state", action="store_true",
                    help="JTC state_interfaces [position, velocity] (vendor config: position only)")
    ap.add_argument("--interpolation", choices=["splines", "none"], default="splines")
    ap.add_argument("--hw-velocity", type=float, default=4.712, help="streaming velocity limit (rad/s)")
    ap.add_argument("--hw-acceleration", type=float, default=1.0, help="streaming acceleration limit (rad/s^2; 0 disables)")
    ap.add_argument("--hw-min-time", type=float, default=0.01, help="streaming command minimum time (s)")
    ap.add_argument("--no-hw-limits", action="store_true", help="disable the streaming follower")
    ap.add_argument("--target-filter-hz", type=float, default=15.0, help="firmware target low-pass (Hz; 0 disables)")
    ap.add_argument("--freeze-joint", help="fault: lock this joint ...")
    ap.add_argument("--freeze-after-s", type=float, help="... from this many wall seconds after start")
    ap.add_argument("--freeze-s", type=float, help="... released after this many seconds (default: never)")
    ap.add_argument("--hold-after-s", type=float, help="fault: collision hold from this many wall seconds after start")
    ap.add_argument("--hold-s", type=float, help="... released after this many seconds (default: never)")
    ap.add_argument("--driver-restart-after-s", type=float,
                    help="fault: the vendor driver restarts at this many wall seconds after start: no joint "
                         "states and commands dropped for --driver-restart-s, the controller's state reset")
    ap.add_argument("--driver-restart-s", type=float, default=3.0, help="... for this long (s)")
    ap.add_argument("--driver-restart-step", type=float, default=0.0,
                    help="... and the arm found this far (rad, every controlled joint) from where it stopped "
                         "when the driver is back (moved by hand)")
    ap.add_argument("--controller-off-after-s", type=float,
                    help="fault: the trajectory controller is switched off at this many wall seconds after "
                         "start (its command subscriptions deleted: the publisher loses its match; the hardware "
                         "holds), on again after --controller-off-s")
    ap.add_argument("--controller-off-s", type=float, default=2.0, help="... for this long (s)")
    ap.add_argument("--sensor-fault", choices=["frozen", "silent", "nan", "missing"],
                    help="fault of the published joint states while the robot keeps moving: frozen "
                         "(the state stops changing), silent (none published), nan (--sensor-fault-joint's "
                         "position NaN), missing (that joint left out)")
    ap.add_argument("--sensor-fault-joint", help="joint of nan/missing (default: the first controlled joint)")
    ap.add_argument("--sensor-fault-after-s", type=float, default=0.0, help="start (wall s after start)")
    ap.add_argument("--sensor-fault-s", type=float, help="length (s; default: to the end)")
    ap.add_argument("--duration", type=float, default=0.0, help="exit after this many wall seconds (0: run until signal)")
    ap.add_argument("--summary", metavar="PATH", help="write the JSON summary here on exit")
    return ap


def main(argv=None) -> int:
    args = make_parser().parse_args(argv)
    if (args.freeze_joint is None) != (args.freeze_after_s is None):
        print("rby1_mujoco: --freeze-joint and --freeze-after-s go together", file=sys.stderr)
        return 2
    if args.freeze_s is not None and args.freeze_joint is None:
        print("rby1_mujoco: --freeze-s goes with --freeze-joint", file=sys.stderr)
        return 2
    if args.hold_s is not None and args.hold_after_s is None:
        print("rby1_mujoco: --hold-s goes with --hold-after-s", file=sys.stderr)
        return 2
    if args.sensor_fault_joint is not None and args.sensor_fault not in ("nan", "missing"):
        print("rby1_mujoco: --sensor-fault-joint goes with --sensor-fault nan|missing", file=sys.stderr)
        return 2

    from cyclonedds.domain import DomainParticipant
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    import ros_types as rt

    stop = {"flag": False, "signal": None}

    def on_signal(signum, _frame):
        stop["flag"] = True
        stop["signal"] = signal.Signals(signum).name

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)

    sim, info, urdf = build_sim(args, clock_origin_ns=time.time_ns())
    if args.freeze_joint is not None and mujoco.mj_name2id(sim.m, mujoco.mjtObj.mjOBJ_JOINT, args.freeze_joint) < 0:
        print(f"rby1_mujoco: --freeze-joint {args.freeze_joint!r} is not in the model", file=sys.stderr)
        return 2

    dp = DomainParticipant(args.domain)
    js_w = DataWriter(dp, Topic(dp, rt.TOPIC_JOINT_STATES, rt.JointState), qos=rt.QOS_RELIABLE)
    traj_t = Topic(dp, rt.TOPIC_TRAJECTORY, rt.JointTrajectory)
    fwd_t = Topic(dp, rt.TOPIC_FORWARD, rt.Float64MultiArray)
    traj_r = DataReader(dp, traj_t, qos=rt.QOS_RELIABLE)
    fwd_r = DataReader(dp, fwd_t, qos=rt.QOS_RELIABLE)
    reset_r = DataReader(dp, Topic(dp, rt.TOPIC_RESET, rt.Float64MultiArray), qos=rt.QOS_RELIABLE)

    period = 1.0 / args.rate_hz
    steps_per_iter = max(1, int(round(period / sim.dt)))
    max_catchup = int(round(MAX_CATCHUP_S / sim.dt))
    hw = "off" if not sim.follower.enabled else (
        f"v {args.hw_velocity:g} rad/s, a {args.hw_acceleration:g} rad/s^2, min time {args.hw_min_time:g} s")
    print(f"rby1_mujoco: version {args.version}, {sim.n} controlled joints, gravity compensation "
          f"{'on' if args.gravity_compensation else 'off'}, force limits "
          f"{'from ' + os.path.basename(urdf) if info.force_limits else 'off'}, JTC "
          f"{'open-loop (from last reference)' if args.open_loop_control else 'closed-loop (from measured)'} "
          f"at {args.controller_rate_hz:g} Hz, hw streaming {hw}, target filter "
          f"{(str(args.target_filter_hz) + ' Hz') if args.target_filter_hz > 0 else 'off'}, domain {args.domain}, "
          f"publishing rt/joint_states ({len(sim.pub_names)} joints) at {args.rate_hz:g} Hz", flush=True)

    c = {"commands_received": 0, "commands_dropped": 0, "commands_discarded": 0, "commands_invalid": 0,
         "trajectories_received": 0, "forward_commands_received": 0, "trajectories_invalid": 0,
         "forward_commands_invalid": 0, "resets_invalid": 0, "commands_during_hold": 0,
         "joint_states_published": 0, "joint_states_faulted": 0, "late_iterations": 0, "dropped_sim_time_s": 0.0}
    invalid_reasons: Dict[str, int] = {}
    last_command: List[float] = sim.reference.tolist()
    last_reset_mono = -math.inf
    work_ms: List[float] = []
    phase = {"inputs": 0.0, "physics": 0.0, "publish": 0.0, "physics_steps": 0}

    def invalid(kind: str, why: str) -> None:
        c["commands_invalid"] += 1
        key = f"{kind}: {why}"
        invalid_reasons[key] = invalid_reasons.get(key, 0) + 1

    t0 = time.monotonic()
    # Simulated time 0 is now, on the wall clock (trajectory stamps are wall-clock times):
    # setting up DDS took a while since the model was built.
    sim.clock_origin_ns = time.time_ns()
    started_wall = sim.clock_origin_ns * 1e-9
    cpu0 = time.process_time()
    tcpu0 = time.thread_time()
    sim_t0 = t0  # wall instant of simulated time 0 (moves when time is dropped)
    next_iter = t0
    js = rt.JointState(header=rt.Header(stamp=rt.now_stamp(), frame_id=""), name=list(sim.pub_names))
    sensor_fault_started = None
    # Timed events: (kind, start wall time, end wall time) as they happen (time.time()).
    events: List[dict] = []
    outage = None  # driver restart in progress: its event
    off = None  # controller off: its event
    try:
        while not stop["flag"]:
            now = time.monotonic()
            if now < next_iter:
                time.sleep(next_iter - now)
                continue
            it_start = now
            next_iter += period
            if next_iter < now - MAX_CATCHUP_S:
                next_iter = now + period
            elapsed = now - t0
            if args.duration and elapsed >= args.duration:
                break

            # faults (wall seconds since start)
            if args.freeze_joint is not None and sim.freeze is None and elapsed >= args.freeze_after_s \
                    and not any(e["kind"] == "freeze" for e in events):
                # Once: a released lock stays released.
                sim.start_freeze(args.freeze_joint, elapsed)
            if args.hold_after_s is not None and sim.hold_q is None and elapsed >= args.hold_after_s \
                    and not any(e["kind"] == "hold" for e in events):
                sim.start_hold(elapsed)
                events.append({"kind": "hold", "start_wall_s": time.time(), "end_wall_s": None})
            if args.freeze_joint is not None and sim.freeze is not None \
                    and not any(e["kind"] == "freeze" for e in events):
                events.append({"kind": "freeze", "joint": args.freeze_joint, "start_wall_s": time.time(),
                               "end_wall_s": None})
            for e in events:
                if e["end_wall_s"] is not None:
                    continue
                if e["kind"] == "hold" and args.hold_s is not None and elapsed >= args.hold_after_s + args.hold_s:
                    sim.end_hold()
                    e["end_wall_s"] = time.time()
                if e["kind"] == "freeze" and args.freeze_s is not None \
                        and elapsed >= args.freeze_after_s + args.freeze_s:
                    sim.end_freeze()
                    e["end_wall_s"] = time.time()
            if args.driver_restart_after_s is not None and outage is None \
                    and not any(e["kind"] == "driver_restart" for e in events) \
                    and elapsed >= args.driver_restart_after_s:
                # The driver goes down: the controller's state is reset; the hardware holds.
                q = sim.measured()
                sim.jtc.reset(q)
                sim.reference = q.copy()
                outage = {"kind": "driver_restart", "start_wall_s": time.time(), "end_wall_s": None,
                          "step_rad": args.driver_restart_step}
                events.append(outage)
            if outage is not None and elapsed >= args.driver_restart_after_s + args.driver_restart_s:
                # Back, with the arm where a hand left it.
                q = sim.measured() + args.driver_restart_step
                q = np.clip(q, sim.lower + 0.05, sim.upper - 0.05)
                sim.reset(q.tolist())
                sim.released_s = sim.sim_time
                outage["end_wall_s"] = time.time()
                outage = None
            if args.controller_off_after_s is not None and off is None \
                    and not any(e["kind"] == "controller_off" for e in events) \
                    and elapsed >= args.controller_off_after_s:
                traj_r.__del__()
                fwd_r.__del__()
                traj_r = fwd_r = None
                sim.jtc.reset(sim.reference.copy())  # the hardware holds the last reference
                off = {"kind": "controller_off", "start_wall_s": time.time(), "end_wall_s": None}
                events.append(off)
            if off is not None and elapsed >= args.controller_off_after_s + args.controller_off_s:
                traj_r = DataReader(dp, traj_t, qos=rt.QOS_RELIABLE)
                fwd_r = DataReader(dp, fwd_t, qos=rt.QOS_RELIABLE)
                sim.released_s = sim.sim_time
                off["end_wall_s"] = time.time()
                off = None

            # inputs: resets first, then commands
            t_in = time.perf_counter()
            for s in reset_r.take(N=100):
                if not isinstance(s, rt.Float64MultiArray):
                    continue
                why = sim.reset(list(s.data))
                if why is None:
                    last_reset_mono = time.monotonic()
                    last_command = list(s.data)
                    # Report the teleported pose at once, before gravity moves it: a client
                    # waits for the exact reset pose to start its clock.
                    js.position, js.velocity, js.effort = sim.joint_state_arrays()
                    js.header.stamp = rt.now_stamp()
                    js_w.write(js)
                    c["joint_states_published"] += 1
                else:
                    c["resets_invalid"] += 1
                    invalid_reasons["reset: " + why] = invalid_reasons.get("reset: " + why, 0) + 1
            quiet = (time.monotonic() - last_reset_mono) < RESET_QUIET_S or outage is not None
            for s in (traj_r.take(N=100) if traj_r is not None else []):
                if not isinstance(s, rt.JointTrajectory):
                    continue
                if quiet:
                    c["commands_discarded"] += 1
                    continue
                msg = to_msg(s, rt)
                why = sim.submit_trajectory(msg)
                if why is None:
                    c["commands_received"] += 1
                    c["trajectories_received"] += 1
                    if sim.hold_q is not None:
                        c["commands_during_hold"] += 1
                    last_command = final_positions(sim, msg)
                else:
                    c["trajectories_invalid"] += 1
                    invalid("trajectory", why)
            for s in (fwd_r.take(N=100) if fwd_r is not None else []):
                if not isinstance(s, rt.Float64MultiArray):
                    continue
                if quiet:
                    c["commands_discarded"] += 1
                    continue
                why = sim.submit_forward(list(s.data))
                if why is None:
                    c["commands_received"] += 1
                    c["forward_commands_received"] += 1
                    if sim.hold_q is not None:
                        c["commands_during_hold"] += 1
                    last_command = list(s.data)
                else:
                    c["forward_commands_invalid"] += 1
                    invalid("forward", why)

            # physics: catch up with the wall clock, at most MAX_CATCHUP_S per iteration
            t_ph = time.perf_counter()
            phase["inputs"] += t_ph - t_in
            due = int((now - sim_t0) / sim.dt) - sim.k
            if due > steps_per_iter + 1:
                c["late_iterations"] += 1
            todo = min(max(due, 0), max_catchup)
            sim.run(todo)
            behind = (now - sim_t0) - sim.k * sim.dt
            if behind > MAX_CATCHUP_S:  # drop the time we cannot simulate; keep the clock on wall time
                sim_t0 += behind
                sim.clock_origin_ns += int(behind * NS)
                c["dropped_sim_time_s"] += behind

            # publish
            t_pub = time.perf_counter()
            phase["physics"] += t_pub - t_ph
            phase["physics_steps"] += todo
            faulty = args.sensor_fault is not None and elapsed >= args.sensor_fault_after_s and (
                args.sensor_fault_s is None or elapsed < args.sensor_fault_after_s + args.sensor_fault_s)
            if faulty and sensor_fault_started is None:
                sensor_fault_started = elapsed
            if outage is not None:
                c["joint_states_faulted"] += 1
                phase["publish"] += time.perf_counter() - t_pub
                work_ms.append((time.monotonic() - it_start) * 1e3)
                continue
            if not faulty or args.sensor_fault != "frozen":
                js.position, js.velocity, js.effort = sim.joint_state_arrays()
            js.header.stamp = rt.now_stamp()
            if faulty and args.sensor_fault in ("nan", "missing"):
                k = sim.pub_names.index(args.sensor_fault_joint or sim.joints[0])
                bad = rt.JointState(header=js.header, name=list(js.name), position=list(js.position),
                                    velocity=list(js.velocity), effort=list(js.effort))
                if args.sensor_fault == "nan":
                    bad.position[k] = math.nan
                else:
                    for f in ("name", "position", "velocity", "effort"):
                        del getattr(bad, f)[k]
                js_w.write(bad)
            elif not (faulty and args.sensor_fault == "silent"):
                js_w.write(js)
            c["joint_states_published"] += int(not (faulty and args.sensor_fault == "silent"))
            c["joint_states_faulted"] += int(faulty)
            phase["publish"] += time.perf_counter() - t_pub
            work_ms.append((time.monotonic() - it_start) * 1e3)
    finally:
        wall = time.monotonic() - t0
        cpu = time.process_time() - cpu0
        tcpu = time.thread_time() - tcpu0
        rep = sim.report()
        w = np.array(work_ms) if work_ms else np.zeros(1)
        summary = {
            "steps": rep["steps"],
            "commands_received": c["commands_received"],
            "commands_dropped": 0,
            "commands_discarded": c["commands_discarded"],
            "commands_invalid": c["commands_invalid"],
            "joint_states_published": c["joint_states_published"],
            "resets": rep["resets"],
            "violation_count": rep["violation_count"],
            "violations": rep["violations"],
            "max_abs_velocity": [rep["max_abs_velocity"][j] for j in sim.joints],  # --joints order
            "last_command": [float(x) for x in last_command],
            "fault_started_s": rep["fault_started_s"],
            "fault_trigger_joint": None,
            "joint_states_faulted": c["joint_states_faulted"],
            "sensor_fault_started_wall_s": sensor_fault_started,
            "tracking_error": rep["tracking_error"],
            "max_abs_velocity_by_joint": rep["max_abs_velocity"],
            "fault_started_wall_s": rep["fault_started_wall_s"],
            "torque_limit_time_s": rep["torque_limit_time_s"],
            "torque_limit_run_after_release_s": rep["torque_limit_run_after_release_s"],
            "events": events,
            "min_limit_margin": rep["min_limit_margin"],
            "late_iterations": c["late_iterations"],
            "started_wall_time_s": started_wall,
            "trajectories_received": c["trajectories_received"],
            "forward_commands_received": c["forward_commands_received"],
            "trajectories_invalid": c["trajectories_invalid"],
            "forward_commands_invalid": c["forward_commands_invalid"],
            "resets_invalid": c["resets_invalid"],
            "invalid_reasons": invalid_reasons,
            "commands_during_hold": c["commands_during_hold"],
            "trajectories_superseded": rep["trajectories_superseded"],
            "partial_trajectories": rep["partial_trajectories"],
            "position_violations": rep["position_violations"],
            "velocity_violations": rep["velocity_violations"],
            "fault_kind": rep["fault_kind"],
            "fault_joint": rep["fault_joint"],
            "sim_time_s": rep["sim_time_s"],
            "wall_time_s": round(wall, 6),
            "dropped_sim_time_s": round(c["dropped_sim_time_s"], 6),
            "cpu_time_s": round(cpu, 6),
            "main_thread_cpu_ms_per_iteration": 1e3 * tcpu / max(1, len(work_ms)),
            "process_cpu_ms_per_iteration": 1e3 * cpu / max(1, len(work_ms)),
            "iteration_work_ms": {"mean": float(w.mean()), "p50": float(np.percentile(w, 50)),
                                  "p99": float(np.percentile(w, 99)), "max": float(w.max())},
            "iteration_phase_ms": {k: (1e3 * v / max(1, len(work_ms)) if k != "physics_steps" else v)
                                   for k, v in phase.items()},
            "physics_step_ms": 1e3 * phase["physics"] / max(1, phase["physics_steps"]),
            "final_position": rep["final_position"],
            "last_reference": rep["last_reference"],
            "exit_signal": stop["signal"],
            "joints": sim.joints,
            "published_joints": sim.pub_names,
            "settings": {
                "version": args.version, "model_dir": os.path.abspath(args.model_dir),
                "urdf": os.path.abspath(urdf) if urdf else None, "force_limits": info.force_limits,
                "gravity_compensation": args.gravity_compensation, "domain": args.domain,
                "rate_hz": args.rate_hz, "controller_rate_hz": args.controller_rate_hz,
                "timestep_s": sim.dt, "open_loop_control": args.open_loop_control,
                "allow_partial_joints_goal": not args.no_partial_joints_goal,
                "jtc_velocity_state": args.jtc_velocity_state, "interpolation": args.interpolation,
                "hw_limits": sim.follower.enabled, "hw_velocity": args.hw_velocity,
                "hw_acceleration": args.hw_acceleration if sim.follower.enabled else 0.0,
                "hw_min_time": args.hw_min_time, "target_filter_hz": args.target_filter_hz,
                "freeze_joint": args.freeze_joint, "freeze_after_s": args.freeze_after_s,
                "hold_after_s": args.hold_after_s, "initial_q": parse_floats(args.initial_q) if args.initial_q else None,
            },
        }
        if args.summary:
            tmp = args.summary + ".tmp"
            with open(tmp, "w") as f:
                json.dump(finite_or_null(summary), f, indent=2, allow_nan=False)
            os.replace(tmp, args.summary)
        print(f"rby1_mujoco: stopped ({stop['signal'] or 'duration'}) after {wall:.2f} s wall, "
              f"{rep['sim_time_s']:.2f} s simulated, {c['joint_states_published']} joint states, "
              f"{c['commands_received']} commands ({c['commands_invalid']} invalid, "
              f"{c['commands_discarded']} discarded), {rep['violation_count']} violations, "
              f"{c['late_iterations']} late iterations, work {w.mean():.3f} ms/iteration, "
              f"cpu {100.0 * cpu / max(wall, 1e-9):.1f} %", flush=True)
    return 0


def finite_or_null(x):
    """JSON has no inf/NaN (serde_json rejects them): non-finite floats become null."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: finite_or_null(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [finite_or_null(v) for v in x]
    return x


def to_msg(s, rt) -> TrajectoryMsg:
    """DDS JointTrajectory -> jtc.TrajectoryMsg (empty sequences -> None)."""
    pts = []
    for p in s.points:
        ne = lambda x: None if len(x) == 0 else np.array(x, dtype=float)
        pts.append(Point(np.array(p.positions, dtype=float), ne(p.velocities), ne(p.accelerations), ne(p.effort),
                         int(p.time_from_start.sec) * NS + int(p.time_from_start.nanosec)))
    return TrajectoryMsg(list(s.joint_names), pts, rt.time_to_ns(s.header.stamp))


def final_positions(sim: Rby1Sim, msg: TrajectoryMsg) -> List[float]:
    """The last point's positions in --joints order (missing joints: the current command)."""
    out = sim.jtc.command.copy()
    out[np.isnan(out)] = sim.reference[np.isnan(out)]
    last = msg.points[-1].positions
    for name, v in zip(msg.joint_names, last):
        out[sim.jtc.index[name]] = v
    return out.tolist()


if __name__ == "__main__":
    sys.exit(main())
