# SPDX-License-Identifier: Apache-2.0
"""``HapticdNode``: hapticd's device in a ROS 2 graph (docs/ros.md).

Three threads, each with its own connection to the daemon (hapticd_client objects are not thread-safe):
  - the executor (rclpy's, the caller's thread): parameters, services, pose subscriptions, the lease's
    heartbeat; it owns the session ``client`` that holds the lease and the objects;
  - the state thread: reads the shared memory (StateReader) at ``rate_hz`` and publishes pose, twist, wrench,
    and the status on /diagnostics (once a second and at once when the fault or liveness changes);
  - the contact thread: a second session (no lease, no objects) subscribed to contact events, published on
    ``~/contacts`` as they arrive.
A failure of the daemon's session (lease lost, daemon gone) ends the node: ``failure`` says why.
"""

from __future__ import annotations

import re
import threading
import time
from typing import Dict, List, Optional

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

import hapticd_client as hc

from .object_words import ObjectWordsError, moved, parse_object_words
from .realtime_offset import RealtimeOffset
from .state_messages import fill_pose, fill_twist, fill_wrench, stamp_of, status

OBJECT_PREFIX = "objects."
OBJECT_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,62}$")
RATE_RANGE_HZ = (1.0, 1000.0)
LEASE_RANGE_S = (0.05, 60.0)
STATUS_PERIOD_S = 1.0
READ_ONLY = ("socket", "instance", "rate_hz", "frame_id", "lease_s", "client_name")


def _error_reason(error: hc.HapticdError) -> str:
    """The protocol's code and message, with the fields the caller needs to correct the request."""
    extra = []
    if error.largest_stable_K is not None:
        extra.append(f"largest_stable_K = {error.largest_stable_K!r} N/m")
    if error.damping_needed is not None:
        extra.append(f"damping_needed = ({error.damping_needed[0]!r}, {error.damping_needed[1]!r}) N s/m")
    message = str(error)
    return f"{error.code}: {message}" + (f" ({'; '.join(extra)})" if extra else "")


class HapticdNode(Node):
    """The bridge. Parameters (read at start): ``socket`` (default: the client's search order), ``instance``,
    ``rate_hz`` (500, 1 .. 1000), ``frame_id`` ("hapticd"), ``lease_s`` (0.5, 0.05 .. 60), ``client_name``;
    ``objects.<name>`` (string, any time): a scene object in hapticctl's words (object_words.py)."""

    def __init__(self, node_name: str = "hapticd", namespace: str = "/", **kwargs) -> None:
        super().__init__(node_name, namespace=namespace, allow_undeclared_parameters=True,
                         automatically_declare_parameters_from_overrides=True, **kwargs)
        self.failure: Optional[str] = None
        self._stop = threading.Event()
        self.socket_path = self._declare("socket", "", "the daemon's socket; empty: $HAPTICD_SOCKET, "
                                                       "$RUNTIME_DIRECTORY, $XDG_RUNTIME_DIR, /run/hapticd")
        self.instance = self._declare("instance", "", "the daemon's instance name (empty: the default instance)")
        self.rate_hz = self._declare_number("rate_hz", 500.0, RATE_RANGE_HZ, "state publication rate, Hz")
        self.frame_id = self._declare("frame_id", "hapticd", "frame of pose, twist, wrench: the device's frame")
        self.lease_s = self._declare_number("lease_s", 0.5, LEASE_RANGE_S,
                                            "the session's lease: without a message for this long the daemon "
                                            "ramps this node's objects out")
        client_name = self._declare("client_name", f"hapticd-ros {self.get_fully_qualified_name()}",
                                    "the name in the daemon's log")
        if not self.frame_id:
            raise ValueError("frame_id = '': accepted: a non-empty frame name")

        self._objects: Dict[str, Dict] = {}  # name -> {"id": int, "description": dict, "subscription": ...}
        self._names_by_id: Dict[int, str] = {}
        # Held from a commit's request to the new ids' registration: a contact event of an object just added
        # (its first tick may come before the reply is read) waits for its name.
        self._registering = threading.Lock()

        # The ROS entities first: creating them costs DDS work that a loaded machine can stretch past the lease, and
        # the lease runs from the session's connection until the executor's keep-alive timer takes over.
        self.pose_pub = self.create_publisher(PoseStamped, "~/pose", 10)
        self.twist_pub = self.create_publisher(TwistStamped, "~/twist", 10)
        self.wrench_pub = self.create_publisher(WrenchStamped, "~/wrench", 10)
        self.contacts_pub = self.create_publisher(DiagnosticArray, "~/contacts", 100)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_service(Trigger, "~/clear_objects", self._clear_objects)

        self.client = self._connect(client_name, self.lease_s)
        self.device = self.client.device

        # Objects given at start (--ros-args -p objects.NAME:="..." or a params file) are committed as one batch.
        initial = list(self.get_parameters_by_prefix(OBJECT_PREFIX.rstrip(".")).values())
        if initial:
            result = self._apply_object_parameters(initial)
            if not result.successful:
                self.client.close()
                raise RuntimeError(f"the objects given at start were refused: {result.reason}")
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.create_timer(max(0.01, self.lease_s / 4.0), self._keep_alive)

        self.published = 0  # state samples published (pose, twist and wrench each)
        self.missed_periods = 0  # publication periods the state thread woke too late for
        self._state_thread = threading.Thread(target=self._publish_state, name="hapticd-ros state", daemon=True)
        self._contact_thread = threading.Thread(target=self._publish_contacts, name="hapticd-ros contacts",
                                                daemon=True)
        self._contact_client = self._connect(client_name + " (contacts)", 0.0)
        self._contact_client.subscribe_contacts()
        # The lease's clock restarts here: the second session's connection above is a round trip to the daemon.
        self.client.keep_alive()
        self._state_thread.start()
        self._contact_thread.start()

    # -- parameters ------------------------------------------------------------------------------------
    def _declare(self, name: str, default: str, description: str) -> str:
        if not self.has_parameter(name):
            self.declare_parameter(name, default, ParameterDescriptor(description=description, read_only=True))
        value = self.get_parameter(name).value
        if not isinstance(value, str):
            raise ValueError(f"{name} = {value!r}: accepted: a string")
        return value

    def _declare_number(self, name: str, default: float, accepted: tuple, description: str) -> float:
        if not self.has_parameter(name):
            descriptor = ParameterDescriptor(description=description, read_only=True, floating_point_range=[
                FloatingPointRange(from_value=accepted[0], to_value=accepted[1], step=0.0)])
            self.declare_parameter(name, default, descriptor)
        value = self.get_parameter(name).value
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not accepted[0] <= value <= accepted[1]:
            raise ValueError(f"{name} = {value!r}: accepted: a number {accepted[0]:g} .. {accepted[1]:g}")
        return float(value)

    def _connect(self, name: str, lease_s: float) -> hc.Client:
        kwargs = {"socket_path": self.socket_path or None, "client": name[:64], "lease_s": lease_s}
        return hc.Client.connect(instance=self.instance or None, **kwargs)

    def _on_set_parameters(self, parameters: List[Parameter]) -> SetParametersResult:
        """Every ``objects.<name>`` in one call becomes one batch (all-or-nothing, as the service's atomic
        variant promises); other parameters are read-only after start (rclpy refuses those itself)."""
        fixed = [p.name for p in parameters if p.name in READ_ONLY]
        if fixed:
            return SetParametersResult(successful=False, reason=(
                f"bad_message: {', '.join(fixed)} are read at start only; accepted: objects.<name> (restart the node "
                "with --ros-args -p NAME:=VALUE to change the others)"))
        objects = [p for p in parameters if p.name.startswith(OBJECT_PREFIX)]
        if not objects:
            return SetParametersResult(successful=True)
        try:
            return self._apply_object_parameters(objects)
        except Exception as e:  # never out of a callback: the caller gets the reason
            return SetParametersResult(successful=False, reason=f"internal: {type(e).__name__}: {e}")

    def _apply_object_parameters(self, parameters: List[Parameter]) -> SetParametersResult:
        batch = hc.Batch()
        added: List[tuple] = []  # (name, description), in the batch's order of adds
        changed: List[tuple] = []
        removed: List[str] = []
        op_parameters: List[str] = []  # the parameter of each operation of the batch
        for p in parameters:
            name = p.name[len(OBJECT_PREFIX):]
            if not OBJECT_NAME.match(name):
                return SetParametersResult(successful=False, reason=(
                    f"bad_message: parameter '{p.name}': the object's name '{name}' is invalid; accepted: a letter "
                    "then letters, digits or '_', at most 63 (it names the topic ~/objects/<name>/pose)"))
            if p.type_ == Parameter.Type.NOT_SET or (p.type_ == Parameter.Type.STRING and not p.value.strip()):
                if name in self._objects:
                    batch.remove(self._objects[name]["id"])
                    removed.append(name)
                    op_parameters.append(p.name)
                continue
            if p.type_ != Parameter.Type.STRING:
                return SetParametersResult(successful=False, reason=(
                    f"bad_message: parameter '{p.name}' = {p.value!r} ({p.type_.name}): accepted: a string, the object "
                    "in hapticctl's words, e.g. \"plane normal=-1,0,0 offset=0.005 criterion=CE2\"; empty: remove it"))
            try:
                description = parse_object_words(p.value)
            except ObjectWordsError as e:
                return SetParametersResult(successful=False, reason=f"bad_message: parameter '{p.name}': {e}")
            if name in self._objects:
                batch.modify(self._objects[name]["id"], description)
                changed.append((name, description))
            else:
                batch.add(description)
                added.append((name, description))
            op_parameters.append(p.name)
        if not batch.ops:
            return SetParametersResult(successful=True)
        with self._registering:
            return self._commit_object_batch(batch, op_parameters, added, changed, removed)

    def _commit_object_batch(self, batch, op_parameters, added, changed, removed) -> SetParametersResult:
        try:
            reply = self.client.commit(batch)
        except hc.HapticdError as e:
            op = (f" (operation {e.op_index}: parameter '{op_parameters[e.op_index]}')"
                  if 0 <= e.op_index < len(op_parameters) else "")
            self.get_logger().warning(f"refused: {_error_reason(e)}{op}")
            if e.code in ("transport", "lease_lost", "slow_consumer"):
                self._fail(f"the daemon's session ended: {e}")
            return SetParametersResult(successful=False, reason=_error_reason(e) + op)
        for name in removed:
            self._forget(name)
        for name, description in changed:
            self._objects[name]["description"] = description
        for (name, description), object_id in zip(added, reply.get("object_ids", [])):
            self._objects[name] = {"id": int(object_id), "description": description,
                                   "subscription": self.create_subscription(
                                       PoseStamped, f"~/objects/{name}/pose",
                                       lambda msg, name=name: self._move(name, msg), 10)}
            self._names_by_id[int(object_id)] = name
        return SetParametersResult(successful=True)

    def _forget(self, name: str) -> None:
        entry = self._objects.pop(name)
        self._names_by_id.pop(entry["id"], None)
        self.destroy_subscription(entry["subscription"])

    def _move(self, name: str, msg: PoseStamped) -> None:
        """A pose on ~/objects/<name>/pose places the object there (object_words.moved): a move, interpolated by
        the loop. The pose must be in the node's frame_id (or name none); its orientation is not used."""
        entry = self._objects.get(name)
        if entry is None:
            return
        if msg.header.frame_id not in ("", self.frame_id):
            self.get_logger().warning(f"~/objects/{name}/pose: frame_id '{msg.header.frame_id}' is not the device's "
                                      f"'{self.frame_id}': pose ignored", throttle_duration_sec=1.0)
            return
        p = msg.pose.position
        try:
            description = moved(entry["description"], (p.x, p.y, p.z))
            self.client.commit(hc.Batch().modify(entry["id"], description))
        except ObjectWordsError as e:
            self.get_logger().warning(f"~/objects/{name}/pose: {e}: pose ignored", throttle_duration_sec=1.0)
            return
        except hc.HapticdError as e:
            self.get_logger().warning(f"~/objects/{name}/pose refused: {_error_reason(e)}", throttle_duration_sec=1.0)
            if e.code in ("transport", "lease_lost", "slow_consumer"):
                self._fail(f"the daemon's session ended: {e}")
            return
        entry["description"] = description

    def _clear_objects(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """~/clear_objects: every object of this node ramps out; their parameters are undeclared."""
        names = list(self._objects)
        try:
            if names:
                self.client.clear()
        except hc.HapticdError as e:
            response.success, response.message = False, _error_reason(e)
            return response
        for name in names:
            self._forget(name)
            if self.has_parameter(OBJECT_PREFIX + name):
                self.undeclare_parameter(OBJECT_PREFIX + name)
        response.success, response.message = True, f"removed {len(names)} object(s): {', '.join(names)}"
        return response

    def object_ids(self) -> Dict[str, int]:
        return {name: entry["id"] for name, entry in self._objects.items()}

    # -- session ---------------------------------------------------------------------------------------
    def _keep_alive(self) -> None:
        try:
            self.client.keep_alive()
            for event in self.client.poll_events():
                if event.code == "objects_removed":
                    for object_id in event.object_ids:
                        name = self._names_by_id.get(object_id)
                        if name is not None:
                            self.get_logger().warning(f"object '{name}' (id {object_id}) ramped out: {event.message}")
                            self._forget(name)
        except hc.HapticdError as e:
            self._fail(f"the daemon's session ended: {e}")

    def _fail(self, why: str) -> None:
        if self.failure is None:
            self.failure = why
            self.get_logger().error(why)
        self._stop.set()

    @property
    def stopped(self) -> bool:
        return self._stop.is_set()

    def shutdown(self) -> None:
        """Stops the threads and ends both sessions (the objects ramp out)."""
        self._stop.set()
        for thread in (self._state_thread, self._contact_thread):
            if thread.is_alive():
                thread.join(2.0)
        for c in (self._contact_client, self.client):
            try:
                c.bye()
            except hc.HapticdError:
                c.close()

    # -- state -----------------------------------------------------------------------------------------
    def _publish_state(self) -> None:
        """Publishes the latest tick every 1/rate_hz s (absolute deadlines; a period woken too late for is
        skipped and counted, never published twice); a tick already published is not published again."""
        try:
            reader = hc.StateReader(self.client.welcome["state_shm"])
        except hc.HapticdError as e:
            self._fail(str(e))
            return
        pose, twist, wrench = PoseStamped(), TwistStamped(), WrenchStamped()
        for msg in (pose, twist, wrench):
            msg.header.frame_id = self.frame_id
        period_ns = int(round(1e9 / self.rate_hz))
        offset = RealtimeOffset()
        deadline = time.monotonic_ns()
        last_tick = -1
        last_status = 0.0
        last_condition = None
        hardware_id = self.device.name
        name = f"{self.get_fully_qualified_name()}: device"
        with reader:
            while not self._stop.is_set():
                try:
                    sample = reader.read()
                except hc.HapticdError as e:
                    sample = None
                    condition = (DiagnosticStatus.ERROR, str(e))
                if sample is not None:
                    if sample.stale:
                        why = (f"the daemon died ({hc.FAULT_NAMES.get(sample.fault, sample.fault)})"
                               if sample.fault in (hc.FAULT_FATAL_SIGNAL, hc.FAULT_TERMINATE)
                               else f"stale: no tick for {sample.heartbeat_age_s:.3f} s")
                        condition = (DiagnosticStatus.STALE, why)
                    elif sample.fault:
                        condition = (DiagnosticStatus.ERROR, f"fault: {hc.FAULT_NAMES.get(sample.fault, sample.fault)}")
                    else:
                        condition = (DiagnosticStatus.OK, "rendering")
                    if not sample.stale and sample.tick != last_tick:
                        stamp = stamp_of(sample.time_s, offset.ns())
                        for msg in (pose, twist, wrench):
                            msg.header.stamp = stamp
                        fill_pose(pose, sample.position)
                        fill_twist(twist, sample.velocity)
                        fill_wrench(wrench, sample.force)
                        self.pose_pub.publish(pose)
                        self.twist_pub.publish(twist)
                        self.wrench_pub.publish(wrench)
                        self.published += 1
                        last_tick = sample.tick
                now = time.monotonic()
                if condition != last_condition or now - last_status >= STATUS_PERIOD_S:
                    values = {} if sample is None else dict(
                        tick=sample.tick, fault=hc.FAULT_NAMES.get(sample.fault, str(sample.fault)),
                        overruns=sample.overruns, objects=sample.objects, heartbeat_age_s=sample.heartbeat_age_s,
                        wake_latency_ns=sample.wake_latency_ns)
                    values.update(published=self.published, missed_periods=self.missed_periods, rate_hz=self.rate_hz,
                                  node_objects=len(self._objects))
                    array = DiagnosticArray()
                    array.header.stamp = self.get_clock().now().to_msg()
                    array.status = [status(condition[0], name, condition[1], hardware_id, **values)]
                    self.diagnostics_pub.publish(array)
                    last_status, last_condition = now, condition
                deadline += period_ns
                wait_ns = deadline - time.monotonic_ns()
                if wait_ns < 0:
                    late = -wait_ns // period_ns
                    self.missed_periods += late
                    deadline += late * period_ns
                    wait_ns += late * period_ns
                self._stop.wait(wait_ns * 1e-9)

    # -- contact events --------------------------------------------------------------------------------
    def _publish_contacts(self) -> None:
        """Each contact event of the daemon (any object, any owner, the config walls) as one DiagnosticArray on
        ~/contacts: stamped with the tick's time, level OK, name "<node>: contact", message "begin" or "end",
        values object_id, object (this node's name for it, else ""), tick, position, force, dropped."""
        name = f"{self.get_fully_qualified_name()}: contact"
        hardware_id = self.device.name
        offset = RealtimeOffset()
        while not self._stop.is_set():
            try:
                event = self._contact_client.next_contact(0.1)
            except hc.HapticdError as e:
                self._fail(f"the daemon's contact session ended: {e}")
                return
            if event is None:
                continue
            with self._registering:
                object_name = self._names_by_id.get(event.object_id, "")
            array = DiagnosticArray()
            array.header.stamp = stamp_of(event.time_s, offset.ns())
            array.header.frame_id = self.frame_id
            array.status = [status(DiagnosticStatus.OK, name, event.event, hardware_id, object_id=event.object_id,
                                   object=object_name, tick=event.tick,
                                   position=",".join(repr(v) for v in event.position),
                                   force=",".join(repr(v) for v in event.force), dropped=event.dropped)]
            self.contacts_pub.publish(array)


def namespace_and_name(fully_qualified: str) -> tuple:
    """``/hapticd`` -> ("/", "hapticd"); ``/robot/left`` -> ("/robot", "left")."""
    path = "/" + fully_qualified.strip("/")
    namespace, _, name = path.rpartition("/")
    return namespace or "/", name
