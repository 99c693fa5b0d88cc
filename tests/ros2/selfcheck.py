#!/usr/bin/env python3
"""Self-check of a ROS 2 venv made by tests/ros2/install.sh (run it inside a private network
namespace: it opens a DDS participant). rclpy initialises with its default middleware, which
must be rmw_fastrtps_cpp (Fast DDS); a node publishes a std_msgs/String to itself and
receives it; every message and service package the peer uses imports.

    netns-run target/ros2/venv-jazzy/bin/python tests/ros2/selfcheck.py jazzy
"""

import importlib
import os
import sys
import time


def main() -> int:
    distro = sys.argv[1] if len(sys.argv) > 1 else "?"
    os.environ.pop("RMW_IMPLEMENTATION", None)  # the default middleware is what is checked
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rclpy.utilities import get_rmw_implementation_identifier
    from std_msgs.msg import String

    for mod in ("sensor_msgs.msg", "trajectory_msgs.msg", "geometry_msgs.msg", "std_msgs.msg",
                "std_srvs.srv", "lifecycle_msgs.msg", "lifecycle_msgs.srv", "rcl_interfaces.msg",
                "rcl_interfaces.srv", "rosgraph_msgs.msg"):
        importlib.import_module(mod)
    rclpy.init()
    try:
        rmw = get_rmw_implementation_identifier()
        if rmw != "rmw_fastrtps_cpp":
            print(f"ros2 selfcheck {distro}: FAIL rmw implementation {rmw!r}, not rmw_fastrtps_cpp")
            return 1
        node = rclpy.create_node("crossym_ros2_selfcheck")
        got = []
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(String, "selfcheck", lambda m: got.append(m.data), qos)
        pub = node.create_publisher(String, "selfcheck", qos)
        deadline = time.monotonic() + 10.0
        while not got and time.monotonic() < deadline:
            pub.publish(String(data="hello"))
            rclpy.spin_once(node, timeout_sec=0.05)
        node.destroy_node()
        if got != [] and got[0] == "hello":
            print(f"ros2 selfcheck {distro}: ok (rclpy from {os.path.dirname(rclpy.__file__)}, {rmw}, "
                  f"a std_msgs/String published to itself and received)")
            return 0
        print(f"ros2 selfcheck {distro}: FAIL no std_msgs/String received from itself within 10 s")
        return 1
    finally:
        rclpy.shutdown()


if __name__ == "__main__":
    sys.exit(main())
