# SPDX-License-Identifier: Apache-2.0
"""The error of every hapticd_client call: the protocol's error code (docs/protocol.md, section 8) or
"transport" when the socket failed, and the server's message, which names the field and its accepted range."""

from __future__ import annotations

from typing import Optional, Tuple

#: The protocol's error codes (docs/protocol.md, section 8), then "transport" and "unknown": the wire strings of
#: ``hapticd::client::ErrorCode`` (src/client/error_code.cpp; a test compares the two). HapticdError may also
#: carry "stale_state", this package's own.
ERROR_CODES = ("protocol_version", "bad_hello", "oversized", "bad_json", "bad_message", "unstable_gains", "unstable_sum",
               "beyond_device_limits", "unknown_criterion", "unknown_object", "not_owner", "capacity", "busy",
               "lease_lost", "slow_consumer", "session_limit", "internal", "transport", "unknown")


class HapticdError(Exception):
    """A refusal, an error reply, an expired lease, or a transport failure.

    Attributes:
        code: "protocol_version", "bad_hello", "oversized", "bad_json", "bad_message", "unstable_gains",
            "unstable_sum", "beyond_device_limits", "unknown_criterion", "unknown_object", "not_owner",
            "capacity", "session_limit", "busy", "internal", "lease_lost", "slow_consumer" (the protocol's),
            "transport", or "stale_state" (StateReader.read(require_live=True): the daemon is dead or stalled).
        op_index: the failing operation of a commit (-1: the summed-gain check, or not a commit).
        largest_stable_K: for "unstable_gains", the largest stable stiffness at the object's damping, N/m.
        damping_needed: for "unstable_gains", the open interval (B_min, B_max) of damping, N s/m, that makes
            the object's stiffness stable; None when no damping does.
        reply: the server's reply as a dict (None for a transport failure).
    """

    def __init__(self, code: str, message: str, op_index: int = -1, largest_stable_K: Optional[float] = None,
                 reply: Optional[dict] = None) -> None:
        super().__init__(message)
        self.code = code
        self.op_index = op_index
        self.largest_stable_K = largest_stable_K
        self.reply = reply
        damping = (reply or {}).get("damping_needed")
        self.damping_needed: Optional[Tuple[float, float]] = (
            (float(damping[0]), float(damping[1]))
            if isinstance(damping, list) and len(damping) == 2 and all(isinstance(b, (int, float)) for b in damping)
            else None)

    @classmethod
    def from_reply(cls, function: str, reply: dict) -> "HapticdError":
        code = str(reply.get("code", "unknown"))
        message = str(reply.get("message", "(no message)"))
        op_index = reply.get("op_index", -1)
        largest = reply.get("largest_stable_K")
        return cls(code, f"{function}: {code}: {message}", op_index if isinstance(op_index, int) else -1,
                   float(largest) if isinstance(largest, (int, float)) else None, reply)
