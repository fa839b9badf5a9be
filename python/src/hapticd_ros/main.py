# SPDX-License-Identifier: Apache-2.0
"""``hapticd-ros``: the console script (docs/ros.md).

    hapticd-ros [--socket PATH] [--instance NAME] [--namespace /hapticd] [--rate 500] [--frame-id hapticd]
                [--lease 0.5] [--ros-args ...]

The flags set the parameters' values and the node's name; ``--ros-args`` sets the others (``-p NAME:=VALUE``,
``--params-file``) and may rename the node (``-r __ns:=``, ``-r __node:=``); a flag wins over ``-p`` of its
parameter. Exit status: 0 on SIGINT/SIGTERM, 1 when the daemon's
session ends (lease lost, daemon gone), 2 for a bad flag or parameter (the message names it), 3 when the
daemon cannot be reached or refuses an object given at start.
"""

from __future__ import annotations

import argparse
import signal
import sys
from typing import List, Optional

import hapticd_client as hc


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="hapticd-ros", description=(
        "hapticd's device as a ROS 2 node: ~/pose, ~/twist, ~/wrench, ~/contacts, /diagnostics; objects as "
        "parameters objects.<name> in hapticctl's words, moved by ~/objects/<name>/pose (docs/ros.md)."))
    p.add_argument("--socket", default=None, help="the daemon's socket (default: $HAPTICD_SOCKET, ...)")
    p.add_argument("--instance", default=None, help="the daemon's instance name")
    p.add_argument("--namespace", default=None,
                   help="the node's fully qualified name, the prefix of its topics (default /hapticd, or "
                        "/hapticd/INSTANCE with --instance)")
    p.add_argument("--rate", type=float, default=None, help="state publication rate, Hz (1 .. 1000; default 500)")
    p.add_argument("--frame-id", default=None, help="frame of pose, twist and wrench (default hapticd)")
    p.add_argument("--lease", type=float, default=None, help="the session's lease, s (0.05 .. 60; default 0.5)")
    return p


def main(argv: Optional[List[str]] = None) -> int:
    argv = list(sys.argv if argv is None else argv)
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from .node import HapticdNode, namespace_and_name

    own = rclpy.utilities.remove_ros_args(argv)[1:]
    args = _parser().parse_args(own)
    overrides = []
    for name, value in (("socket", args.socket), ("instance", args.instance), ("rate_hz", args.rate),
                        ("frame_id", args.frame_id), ("lease_s", args.lease)):
        if value is not None:
            overrides.append(Parameter(name, value=value))
    fqn = args.namespace or ("/hapticd/" + args.instance if args.instance else "/hapticd")
    namespace, node_name = namespace_and_name(fqn)
    rclpy.init(args=argv, signal_handler_options=rclpy.signals.SignalHandlerOptions.NO)
    stop = {"signal": None}

    def on_signal(number, _frame):
        stop["signal"] = number

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    node = None
    try:
        try:
            node = HapticdNode(node_name, namespace, parameter_overrides=overrides)
        except ValueError as e:
            print(f"hapticd-ros: error: {e}", file=sys.stderr)
            return 2
        except hc.HapticdError as e:
            print(f"hapticd-ros: error: {e.code}: {e}", file=sys.stderr)
            return 3
        except RuntimeError as e:
            print(f"hapticd-ros: error: {e}", file=sys.stderr)
            return 3
        node.get_logger().info(
            f"serving {node.device.name} ({node.device.axes} axes) at {node.rate_hz:g} Hz as "
            f"{node.get_fully_qualified_name()}, lease {node.lease_s:g} s")
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while stop["signal"] is None and not node.stopped:
            try:
                executor.spin_once(timeout_sec=0.05)
            except ExternalShutdownException:
                break
        return 1 if node.failure else 0
    finally:
        if node is not None:
            node.shutdown()
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()


if __name__ == "__main__":
    sys.exit(main())
