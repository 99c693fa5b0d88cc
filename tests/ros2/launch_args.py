#!/usr/bin/env python3
"""Print the command line `ros2 launch crossym rby1.launch.py` would start, without launch.

launch and launch_ros are not on PyPI, so the launch file is imported with small stub
modules standing in for them: DeclareLaunchArgument records defaults, LaunchConfiguration
resolves to the default (or to a `name:=value` given here, as on the ros2 launch command
line), Node/LifecycleNode record their keyword arguments, and the command is then assembled
in the order launch_ros's Node action builds it:

    [<prefix>/lib/<package>/<executable>, *arguments,
     ('--ros-args', *ros_arguments  -- only when ros_arguments is given),
     '--ros-args', '-r', '__node:=NAME', '-r', '__ns:=/NS',
     ('--params-file', FILE | '-p', 'name:=value') per `parameters` entry, in order,
     ('-r', 'from:=to') per remapping]

Source: github.com/ros2/launch_ros, launch_ros/launch_ros/actions/node.py, Node.__init__
(cmd = executable + arguments + ros_arguments + '--ros-args' + '-r' name placeholder),
Node._perform_substitutions (appends '-r' ns placeholder, then global params, then
`parameters`, then remappings) and Node.execute (fills the placeholders: '__node:=NAME',
'__ns:=NS'); branch jazzy at 62c56e53e86812023697fe330c83d327f54e7b18 (tag 0.26.6) and
rolling at f9ab9371824d470bca47602bc7d277eb2217c90d (0.28.0 + 1, Kilted's series): the
same code in both. Details reproduced:
  - the namespace is made absolute (launch_ros.utilities.make_namespace_absolute): ''
    gives '-r __ns:=/', 'robot1' gives '-r __ns:=/robot1';
  - a parameters entry that is a path to a missing file is skipped with a warning;
  - the executable is found by ExecutableInPackage in <prefix>/lib/<package>/ (the prefix
    from the ament index, AMENT_PREFIX_PATH).

    AMENT_PREFIX_PATH=target/ros2/pkg-jazzy/install/crossym \\
        python3 tests/ros2/launch_args.py [--launch-file F] [--shell] [name:=value ...]

Prints the argument vector as a JSON array (or, with --shell, as one shell-quoted line) on
stdout; environment variables the launch file sets for the node go to stderr as `env: K=V`.
The launch file is the installed share/crossym/launch/rby1.launch.py by default.
"""
import argparse
import importlib.util
import json
import os
import shlex
import sys
import types


class _Sub:
    """Base of the stub substitutions."""


class LaunchConfiguration(_Sub):
    def __init__(self, name, default=None):
        self.name = name
        self.default = default


class NotEqualsSubstitution(_Sub):
    def __init__(self, left, right):
        self.left, self.right = left, right


class EqualsSubstitution(_Sub):
    def __init__(self, left, right):
        self.left, self.right = left, right


class DeclareLaunchArgument:
    def __init__(self, name, default_value=None, description='', **kwargs):
        self.name, self.default_value, self.kwargs = name, default_value, kwargs


class SetEnvironmentVariable:
    def __init__(self, name, value, condition=None):
        self.name, self.value, self.condition = name, value, condition


class IfCondition:
    def __init__(self, predicate):
        self.predicate = predicate


class UnlessCondition(IfCondition):
    pass


class LaunchDescription:
    def __init__(self, entities=()):
        self.entities = list(entities)


class Node:
    """Records the keyword arguments, as launch_ros.actions.Node receives them."""

    def __init__(self, *, executable, package=None, name=None, namespace=None,
                 parameters=None, remappings=None, ros_arguments=None, arguments=None,
                 **kwargs):
        self.kwargs = dict(executable=executable, package=package, name=name,
                           namespace=namespace, parameters=parameters, remappings=remappings,
                           ros_arguments=ros_arguments, arguments=arguments, **kwargs)


class LifecycleNode(Node):
    def __init__(self, *, name, namespace, **kwargs):  # both required, as in launch_ros
        super().__init__(name=name, namespace=namespace, **kwargs)


def _install_stubs():
    mods = {}
    for name in ('launch', 'launch.actions', 'launch.conditions', 'launch.substitutions',
                 'launch_ros', 'launch_ros.actions'):
        mods[name] = types.ModuleType(name)
        sys.modules[name] = mods[name]
    mods['launch'].LaunchDescription = LaunchDescription
    mods['launch'].actions = mods['launch.actions']
    mods['launch'].conditions = mods['launch.conditions']
    mods['launch'].substitutions = mods['launch.substitutions']
    mods['launch.actions'].DeclareLaunchArgument = DeclareLaunchArgument
    mods['launch.actions'].SetEnvironmentVariable = SetEnvironmentVariable
    mods['launch.conditions'].IfCondition = IfCondition
    mods['launch.conditions'].UnlessCondition = UnlessCondition
    mods['launch.substitutions'].LaunchConfiguration = LaunchConfiguration
    mods['launch.substitutions'].NotEqualsSubstitution = NotEqualsSubstitution
    mods['launch.substitutions'].EqualsSubstitution = EqualsSubstitution
    mods['launch_ros'].actions = mods['launch_ros.actions']
    mods['launch_ros.actions'].Node = Node
    mods['launch_ros.actions'].LifecycleNode = LifecycleNode


def _perform(value, config):
    """Evaluates a substitution (or a list of them, concatenated) to a string."""
    if value is None:
        return None
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)):
        return ''.join(_perform(v, config) for v in value)
    if isinstance(value, LaunchConfiguration):
        if value.name in config:
            return config[value.name]
        if value.default is not None:
            return _perform(value.default, config)
        raise SystemExit(f'launch_args.py: launch configuration {value.name!r} is not set')
    if isinstance(value, NotEqualsSubstitution):
        return str(_perform(value.left, config) != _perform(value.right, config)).lower()
    if isinstance(value, EqualsSubstitution):
        return str(_perform(value.left, config) == _perform(value.right, config)).lower()
    raise SystemExit(f'launch_args.py: no stub for the substitution {value!r}')


def _condition_holds(condition, config):
    if condition is None:
        return True
    text = _perform(condition.predicate, config).strip().lower()
    if text not in ('true', 'false', '1', '0'):
        raise SystemExit(f'launch_args.py: condition evaluated to {text!r}, not a boolean')
    holds = text in ('true', '1')
    return not holds if isinstance(condition, UnlessCondition) else holds


def node_command(description, overrides):
    """(argv, env) of the one Node in the launch description."""
    config = {}
    env = {}
    nodes = []
    for entity in description.entities:
        if isinstance(entity, DeclareLaunchArgument):
            if entity.name in overrides:
                config[entity.name] = overrides[entity.name]
            elif entity.default_value is not None:
                config[entity.name] = _perform(entity.default_value, config)
        elif isinstance(entity, SetEnvironmentVariable):
            if _condition_holds(entity.condition, config):
                env[_perform(entity.name, config)] = _perform(entity.value, config)
        elif isinstance(entity, Node):
            nodes.append(entity.kwargs)
        else:
            raise SystemExit(f'launch_args.py: no stub for {type(entity).__name__}')
    unknown = set(overrides) - set(config)
    if unknown:
        raise SystemExit(f'launch_args.py: not launch arguments of this file: {sorted(unknown)}')
    if len(nodes) != 1:
        raise SystemExit(f'launch_args.py: expected one node, found {len(nodes)}')
    k = nodes[0]

    executable = _perform(k['executable'], config)
    if k['package'] is not None:
        from ament_index_python.packages import get_package_prefix
        package = _perform(k['package'], config)
        executable = os.path.join(get_package_prefix(package), 'lib', package, executable)
        if not os.access(executable, os.X_OK):
            raise SystemExit(f'launch_args.py: {executable} is not an executable')
    cmd = [executable]
    cmd += [_perform(a, config) for a in (k['arguments'] or [])]
    if k['ros_arguments'] is not None:
        cmd += ['--ros-args'] + [_perform(a, config) for a in k['ros_arguments']]
    cmd += ['--ros-args']
    if k['name'] is not None:
        cmd += ['-r', '__node:=' + _perform(k['name'], config).lstrip('/')]
    if k['namespace'] is not None:
        ns = _perform(k['namespace'], config)
        if not ns.startswith('/'):
            ns = '/' + ns
        if ns != '/':
            ns = ns.rstrip('/')
        cmd += ['-r', '__ns:=' + ns]
    for p in k['parameters'] or []:
        if isinstance(p, dict):
            raise SystemExit('launch_args.py: dictionary parameters are not stubbed '
                             '(launch_ros writes them to a temporary file)')
        path = _perform(p, config)
        if not os.path.isfile(path):
            print(f'launch_args.py: [WARNING] Parameter file path is not a file: {path} '
                  '(skipped, as launch_ros does)', file=sys.stderr)
            continue
        cmd += ['--params-file', path]
    for src, dst in k['remappings'] or []:
        cmd += ['-r', f'{_perform(src, config)}:={_perform(dst, config)}']
    return cmd, env


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--launch-file', help='default: share/crossym/launch/rby1.launch.py '
                        'of the crossym package in the ament index')
    parser.add_argument('--shell', action='store_true', help='print one shell-quoted line')
    parser.add_argument('launch_arguments', nargs='*', metavar='name:=value')
    args = parser.parse_args()
    overrides = {}
    for a in args.launch_arguments:
        name, sep, value = a.partition(':=')
        if not sep:
            parser.error(f'launch arguments are name:=value, not {a!r}')
        overrides[name] = value

    _install_stubs()
    path = args.launch_file
    if path is None:
        from ament_index_python.packages import get_package_share_directory
        path = os.path.join(get_package_share_directory('crossym'), 'launch', 'rby1.launch.py')
    spec = importlib.util.spec_from_file_location('crossym_launch_file', path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    cmd, env = node_command(module.generate_launch_description(), overrides)
    for k, v in env.items():
        print(f'env: {k}={v}', file=sys.stderr)
    print(shlex.join(cmd) if args.shell else json.dumps(cmd))


if __name__ == '__main__':
    main()
