# SPDX-License-Identifier: Apache-2.0
"""hapticd instances: several daemons on one machine, one per device, told apart by a name (docs/hapticd.md,
"Instances"). Instance NAME: socket ``hapticd-NAME.sock``, state ``/hapticd-NAME-state``; no name (the default
instance): ``hapticd.sock``, ``/hapticd-state``. The same rules as include/hapticd/instance.hpp."""

import os
import re
from typing import Optional

INSTANCE_NAME_FORM = "1 to 32 characters of a-z, 0-9, '_' and '-', starting with a letter or a digit (e.g. left)"
_INSTANCE_NAME = re.compile(r"[a-z0-9][a-z0-9_-]{0,31}")


def valid_instance_name(name: str) -> bool:
    """NAME matches ``[a-z0-9][a-z0-9_-]{0,31}``."""
    return isinstance(name, str) and _INSTANCE_NAME.fullmatch(name) is not None


def check_instance_name(name: str, what: str = "instance") -> str:
    """``name`` when valid, else ValueError naming ``what`` and the accepted form."""
    if not valid_instance_name(name):
        raise ValueError(f"{what} = {name!r} is invalid; accepted: {INSTANCE_NAME_FORM}")
    return name


def instance_socket_file(instance: Optional[str]) -> str:
    return f"hapticd-{instance}.sock" if instance else "hapticd.sock"


def instance_state_shm(instance: Optional[str]) -> str:
    return f"/hapticd-{instance}-state" if instance else "/hapticd-state"


def runtime_socket_directory() -> str:
    """``$RUNTIME_DIRECTORY``, else ``$XDG_RUNTIME_DIR``, else ``/run/hapticd`` (the daemon's order)."""
    for var in ("RUNTIME_DIRECTORY", "XDG_RUNTIME_DIR"):
        if os.environ.get(var):
            return os.environ[var]
    return "/run/hapticd"


def instance_socket_path(instance: Optional[str]) -> str:
    return os.path.join(runtime_socket_directory(), instance_socket_file(instance))
