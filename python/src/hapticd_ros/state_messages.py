# SPDX-License-Identifier: Apache-2.0
"""The device's state (one tick of the shared memory, hapticd_client.StateSample) as ROS 2 messages.

Stamps: the tick's wake-up time ``time_s`` is CLOCK_MONOTONIC; ROS stamps are the system clock (ROS time
without simulated time), so a stamp is ``time_s + (CLOCK_REALTIME - CLOCK_MONOTONIC)``, the offset measured by
the publishing thread's realtime_offset.RealtimeOffset. A subscriber's ``now - stamp`` is then the time from the tick
to its callback."""

from __future__ import annotations

from typing import Sequence

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped


def stamp_of(time_s: float, offset_ns: int) -> Time:
    """The ROS stamp (system clock) of a CLOCK_MONOTONIC time in seconds."""
    ns = int(round(time_s * 1e9)) + offset_ns
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def fill_pose(msg: PoseStamped, position: Sequence[float]) -> None:
    """The handle's position (m); the orientation is the identity (hapticd renders translations only)."""
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in position)
    msg.pose.orientation.w = 1.0


def fill_twist(msg: TwistStamped, velocity: Sequence[float]) -> None:
    """The loop's velocity estimate (m/s; the welcome's velocity_estimator); no angular velocity."""
    msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z = (float(v) for v in velocity)


def fill_wrench(msg: WrenchStamped, force: Sequence[float]) -> None:
    """The force commanded to the device this tick (N), after delay, saturation and rate limit; no torque."""
    msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = (float(v) for v in force)


def key_values(**values) -> list:
    """DiagnosticStatus values: each keyword as a KeyValue, numbers written with repr (exact round trip)."""
    return [KeyValue(key=k, value=v if isinstance(v, str) else repr(v)) for k, v in values.items()]


def status(level: bytes, name: str, message: str, hardware_id: str, **values) -> DiagnosticStatus:
    return DiagnosticStatus(level=level, name=name, message=message, hardware_id=hardware_id,
                            values=key_values(**values))
