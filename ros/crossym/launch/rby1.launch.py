# Starts the crossym node beside the RB-Y1 vendor stack (rby1_hardware / ros2_control).
#
#   ros2 launch crossym rby1.launch.py namespace:=robot1
#   ros2 launch crossym rby1.launch.py config:=/path/to/my-rby1.toml params_file:=/path/to/p.yaml
#
# The node is a lifecycle node and, with an RB-Y1 config, starts INACTIVE (it commands
# nothing until activated): once the vendor stack publishes joint states, run
#
#   ros2 lifecycle set /crossym activate            (or /robot1/crossym with namespace:=robot1)
#   crossym lifecycle set activate                  (the same without the ros2 CLI)
#
# Launch arguments:
#   namespace    node namespace (default: none, the node is /crossym)
#   config       crossym config (TOML); default: the installed config/rby1-letters.toml, whose
#                relative paths (../robots/..., ../data/policies/...) resolve inside
#                share/crossym/ because the install keeps the repository's layout
#   params_file  ROS parameters file (default: the installed config/ros/crossym.params.yaml)
#   ros_distro   sets ROS_DISTRO for the node only when given (default: unset, inherited)
#
# launch_ros runs: <lib/crossym/crossym> node --config CONFIG --ros-args -r __node:=crossym
#   -r __ns:=/NAMESPACE --params-file PARAMS_FILE   (tests/ros2/launch_args.py prints it).
import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, NotEqualsSubstitution
from launch_ros.actions import LifecycleNode


def generate_launch_description():
    share = get_package_share_directory('crossym')
    return LaunchDescription([
        DeclareLaunchArgument(
            'namespace', default_value='',
            description='Node namespace (e.g. robot1): the node is /NAMESPACE/crossym'),
        DeclareLaunchArgument(
            'config', default_value=os.path.join(share, 'config', 'rby1-letters.toml'),
            description='crossym config (TOML) with [robot] and [node]'),
        DeclareLaunchArgument(
            'params_file',
            default_value=os.path.join(share, 'config', 'ros', 'crossym.params.yaml'),
            description='ROS parameters file passed as --params-file'),
        DeclareLaunchArgument(
            'ros_distro', default_value='',
            description='ROS_DISTRO for the node (default: inherited)'),
        SetEnvironmentVariable(
            'ROS_DISTRO', LaunchConfiguration('ros_distro'),
            condition=IfCondition(NotEqualsSubstitution(LaunchConfiguration('ros_distro'), ''))),
        # Starts inactive with RB-Y1 configs: `ros2 lifecycle set /crossym activate`.
        LifecycleNode(
            package='crossym',
            executable='crossym',
            name='crossym',
            namespace=LaunchConfiguration('namespace'),
            arguments=['node', '--config', LaunchConfiguration('config')],
            parameters=[LaunchConfiguration('params_file')],
            output='screen',
        ),
    ])
