// SPDX-License-Identifier: Apache-2.0
// A triangle mesh read from an STL (ASCII or binary) or OBJ file for `hapticctl add mesh FILE` (docs/clients.md),
// with Open Asset Import (assimp, Debian libassimp-dev): every mesh of the file triangulated, identical vertices
// joined (an STL repeats each vertex per triangle; a closed solid needs them shared), scaled to metres. The client
// reads the file; the daemon never opens one (docs/protocol.md, section 4a).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hapticd/client.hpp"

namespace hapticctl {

struct MeshFile {
    std::vector<hapticd::client::Vec3> vertices;          // m (the file's units times `scale`)
    std::vector<std::array<std::uint32_t, 3>> triangles;  // outward normal (b - a) x (c - a)
};

// Throws SpecError naming the file and what is wrong (unreadable, no triangles, scale not finite and > 0).
MeshFile load_mesh_file(const std::string& path, double scale);

}  // namespace hapticctl
