#!/usr/bin/env python3
"""Writes tests/ros2/requirements-DISTRO.txt from a venv where the top-level packages below
were installed (`pip install` of TOP, unpinned): every distribution pip installed, pinned
`==`, grouped under the top-level requirement that pulled it in, each group headed by a
comment saying what it is for. Run with the venv's python when bumping versions:

    target/ros2/venv-jazzy/bin/python tests/ros2/freeze_requirements.py jazzy > tests/ros2/requirements-jazzy.txt

(the ros-wheels embed their ROS packages' own *.egg-info metadata, e.g. `rclpy 7.1.5`
inside `ros-rclpy 7.1.6`: those are not pip distributions and are left out).
"""

import importlib.metadata as md
import sys

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name


def top(distro):
    """(requirement without version, what it is for), in install order."""
    d = distro
    common = [
        (f"ros-{d}-rclpy[fastrtps]", "rclpy (ROS 2's Python client library: rcl, rmw) with rmw_fastrtps_cpp (Fast DDS, ROS 2's default middleware): the peer's runtime"),
        (f"ros-{d}-std-msgs", "std_msgs (Float64MultiArray: velocity and position commands; Header)"),
        (f"ros-{d}-sensor-msgs", "sensor_msgs (JointState: the robot stand-in's /joint_states)"),
        (f"ros-{d}-trajectory-msgs", "trajectory_msgs (JointTrajectory: RB-Y1's trajectory commands)"),
        (f"ros-{d}-geometry-msgs", "geometry_msgs (PoseStamped: task poses; TransformStamped for /tf)"),
        (f"ros-{d}-std-srvs", "std_srvs (SetBool ~/pause, Trigger ~/reset)"),
        (f"ros-{d}-lifecycle-msgs", "lifecycle_msgs (GetState, ChangeState, GetAvailableStates/Transitions, TransitionEvent)"),
        (f"ros-{d}-rcl-interfaces", "rcl_interfaces (parameter services, /rosout Log)"),
        (f"ros-{d}-rosidl-default-generators", "rosidl generators (C, C++, Python, type support): build crossym_msgs"),
        (f"ros-{d}-rosidl-core-generators", "rosidl core generators (needed by rosidl_default_generators' CMake config, not declared by its wheel)"),
        (f"ros-{d}-ament-cmake", "ament_cmake (crossym_msgs' build type)"),
        (f"ros-{d}-ament-package", "ament_package (package.xml parsing for ament_cmake)"),
        (f"ros-{d}-ament-cmake-include-directories", "ament_cmake subpackage needed by ament_cmake's CMake config (not declared by its wheel)"),
        (f"ros-{d}-ament-cmake-ros", "ament_cmake_ros (found by rosidl's CMake configs; not declared by their wheels)"),
        (f"ros-{d}-ament-cmake-gmock", "ament_cmake_gmock (found by ament_cmake_ros' CMake config; not declared)"),
        (f"ros-{d}-ament-cmake-gtest", "ament_cmake_gtest (found by ament_cmake_ros' CMake config; not declared)"),
        (f"ros-{d}-ament-cmake-pytest", "ament_cmake_pytest (found by ament_cmake_ros' CMake config; not declared)"),
    ]
    per = {
        "jazzy": [(f"ros-{d}-python-cmake-module", "python_cmake_module (Jazzy's rosidl_generator_py finds Python with it; not declared)")],
        "kilted": [(f"ros-{d}-ament-cmake-ros-core", "ament_cmake_ros_core (Kilted's ament_cmake_ros CMake config finds it; not declared)")],
    }[distro]
    tools = [
        ("colcon-core", "colcon (the build tool)"),
        ("colcon-cmake", "colcon's CMake package support (builds crossym_msgs as a CMake package)"),
        ("catkin-pkg", "catkin_pkg (ament_cmake_core parses package.xml with it; not declared by the wheels)"),
        ("cmake", "CMake (this machine has none; 3.31 like the CMake ROS 2 is built with, not 4.x)"),
    ]
    return common + per + tools


def main():
    distro = sys.argv[1]
    installed = {}
    for d in md.distributions():
        if not str(getattr(d, "_path", "")).endswith(".dist-info"):
            continue  # embedded ROS egg-info
        if (d.read_text("INSTALLER") or "").strip() != "pip":
            continue
        name = canonicalize_name(d.metadata["Name"])
        if name in ("pip", "setuptools"):
            continue
        installed[name] = d
    seen = set()
    groups = []
    for spec, purpose in top(distro):
        req = Requirement(spec)
        root = canonicalize_name(req.name)
        if root not in installed:
            sys.exit(f"{req.name} is not installed in this venv")
        members = []
        todo = [(root, set(req.extras))]
        while todo:
            name, extras = todo.pop()
            if name in seen or name not in installed:
                continue
            seen.add(name)
            if name != root:
                members.append(name)
            for r in installed[name].requires or []:
                rq = Requirement(r)
                envs = [{"extra": e} for e in (extras or {""})]
                if rq.marker is None or any(rq.marker.evaluate(e) for e in envs):
                    todo.append((canonicalize_name(rq.name), set(rq.extras)))
        groups.append((spec, purpose, root, sorted(members)))
    rest = sorted(set(installed) - seen)
    if rest:
        sys.exit(f"installed but pulled by no top-level requirement: {rest}")
    out = [f"# Python venv target/ros2/venv-{distro} (tests/ros2/install.sh): ROS 2 {distro.capitalize()}'s rclpy with",
           "# Fast DDS and crossym_msgs' build toolchain, all from PyPI wheels; every distribution pinned.",
           "# Generated by tests/ros2/freeze_requirements.py; installed with --no-deps (this list is complete).",
           ""]
    for spec, purpose, root, members in groups:
        d = installed[root]
        out.append(f"# {purpose}")
        out.append(f"{spec.split('[')[0]}{'[' + spec.split('[')[1] if '[' in spec else ''}=={d.version}")
        if members:
            out.append(f"#   pulled in by {spec.split('[')[0]}:")
            out += [f"{installed[m].metadata['Name']}=={installed[m].version}" for m in members]
        out.append("")
    print("\n".join(out).rstrip())


if __name__ == "__main__":
    main()
