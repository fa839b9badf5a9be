# SPDX-License-Identifier: Apache-2.0
"""The mesh objects' god-object proxies in hapticd-scope (docs/scope.md, "Mesh objects").

The state's bytes 600..1119 (include/hapticd/state_layout.hpp, docs/protocol.md section 6) hold, per tick,
``mesh_slot_mask`` (bit s: slot s renders a mesh), ``mesh_proxies`` (entries written, at most 7) and the entries:
the proxy (m, device frame), the active constraints' unit normals, one active triangle, the slot, the number of
constraints, flags and the object id. The scope's samples are the state's fields (bytes 128..575) followed by that
block, both of the same tick (one seqlock read, ``StateReader.read_raw_meshes``).

Per object row the plot needs, for the mesh objects: the proxy where the sample has one for the row's object id
(NaN elsewhere), and the penetration |proxy - handle| (m): the spring K (proxy - handle) the object renders
stretches by it. The handle is the state's ``position`` (axes beyond the device's are 0, as in the state).
"""

from __future__ import annotations

from typing import Tuple

import numpy as np

from .state import MESH_BLOCK_SIZE, MESH_PROXY_CAPACITY

# One StateMeshProxy (72 bytes).
MESH_PROXY_DTYPE = np.dtype({
    "names": ["proxy", "normal", "triangle", "slot", "constraints", "flags", "object_id"],
    "formats": [("<f8", (3,)), ("<f4", (3, 3)), "<u4", "u1", "u1", "u1", "<u4"],
    "offsets": [0, 24, 60, 64, 65, 66, 68],
    "itemsize": 72,
})
# The block at byte 600 of the state.
MESH_DTYPE = np.dtype({
    "names": ["mesh_slot_mask", "mesh_proxies", "mesh_proxy"],
    "formats": ["<u8", "<u4", (MESH_PROXY_DTYPE, (MESH_PROXY_CAPACITY,))],
    "offsets": [0, 8, 16],
    "itemsize": MESH_BLOCK_SIZE,
})
assert MESH_DTYPE.itemsize == 520


def sample_dtype(state_dtype: np.dtype) -> np.dtype:
    """The state's fields (``state_dtype``, 448 bytes) followed by the mesh block: one sample of the scope."""
    names = list(state_dtype.names) + list(MESH_DTYPE.names)
    formats = [state_dtype.fields[n][0] for n in state_dtype.names] + [MESH_DTYPE.fields[n][0] for n in MESH_DTYPE.names]
    offsets = ([state_dtype.fields[n][1] for n in state_dtype.names]
               + [state_dtype.itemsize + MESH_DTYPE.fields[n][1] for n in MESH_DTYPE.names])
    return np.dtype({"names": names, "formats": formats, "offsets": offsets,
                     "itemsize": state_dtype.itemsize + MESH_DTYPE.itemsize})


def has_meshes(samples: np.ndarray) -> bool:
    """Whether the samples carry the mesh block (a plain STATE_DTYPE array does not)."""
    return samples.dtype.names is not None and "mesh_proxy" in samples.dtype.names


def proxy_rows(samples: np.ndarray, ids: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per sample i and object id k: the proxy (n, k, 3) in m and the penetration |proxy - position| (n, k) in m,
    NaN where sample i has no proxy of object k; the constraints (n, k), -1 there."""
    n, k = len(samples), len(ids)
    proxy = np.full((n, k, 3), np.nan)
    constraints = np.full((n, k), -1, np.int64)
    if has_meshes(samples) and n and k:
        entries = samples["mesh_proxy"]  # (n, 7)
        valid = np.arange(MESH_PROXY_CAPACITY)[None, :] < np.minimum(samples["mesh_proxies"], MESH_PROXY_CAPACITY)[:, None]
        for j, object_id in enumerate(ids):
            match = valid & (entries["object_id"].astype(np.int64) == int(object_id))  # (n, 7): at most one per row
            rows = match.any(axis=1)
            first = match.argmax(axis=1)
            chosen = entries[np.arange(n), first]
            proxy[rows, j] = chosen["proxy"][rows]
            constraints[rows, j] = chosen["constraints"][rows]
    penetration = np.linalg.norm(proxy - samples["position"][:, None, :], axis=2) if n else np.zeros((0, k))
    return proxy, penetration, constraints


def meshes_beyond(sample) -> int:
    """Mesh slots of one sample whose proxy the state does not hold (beyond the first 7)."""
    return max(0, bin(int(sample["mesh_slot_mask"])).count("1") - int(sample["mesh_proxies"]))
