# SPDX-License-Identifier: Apache-2.0
"""hapticd_client: the dependency-free Python client of ``hapticd --serve`` (protocol version 1).

    from hapticd_client import Client, StateReader, plane
    with Client.connect(client="demo", lease_s=0.5) as c:
        wall = c.add(plane(normal=(0, 0, 1), offset=0.0, criterion="CE2"))
        with StateReader(c.welcome["state_shm"]) as state:
            print(state.read())

The protocol: docs/protocol.md; this module and its examples: docs/clients.md.
"""

from .client import (CONTACT_QUEUE_CAPACITY, EVENT_QUEUE_CAPACITY, MAX_MESSAGE_BYTES, PROTOCOL_VERSION, Client, ContactEvent, Event,
                     default_socket_path)
from .device import DeviceInfo
from .errors import ERROR_CODES, HapticdError
from .instance import INSTANCE_NAME_FORM, instance_socket_path, instance_state_shm, valid_instance_name
from .meshes import box, icosphere, mesh, torus
from .objects import Batch, field, gains, plane, spring
from .state_source import StateSource, sample_from_state_message
from .state import (FAULT_FATAL_SIGNAL, FAULT_NAMES, FAULT_TERMINATE, MeshProxy, StateFault, StateReader, StateSample,
                    shm_path, stale_after_s)

__all__ = [
    "Batch",
    "CONTACT_QUEUE_CAPACITY",
    "Client",
    "ContactEvent",
    "DeviceInfo",
    "ERROR_CODES",
    "EVENT_QUEUE_CAPACITY",
    "Event",
    "FAULT_FATAL_SIGNAL",
    "FAULT_NAMES",
    "FAULT_TERMINATE",
    "HapticdError",
    "INSTANCE_NAME_FORM",
    "MAX_MESSAGE_BYTES",
    "MeshProxy",
    "PROTOCOL_VERSION",
    "StateFault",
    "StateReader",
    "StateSample",
    "StateSource",
    "box",
    "default_socket_path",
    "field",
    "gains",
    "icosphere",
    "instance_socket_path",
    "instance_state_shm",
    "mesh",
    "plane",
    "sample_from_state_message",
    "shm_path",
    "spring",
    "stale_after_s",
    "torus",
    "valid_instance_name",
]
