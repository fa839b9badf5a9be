// SPDX-License-Identifier: Apache-2.0
#include "mesh_file.hpp"

#include <cmath>

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "object_spec.hpp"

namespace hapticctl {

MeshFile load_mesh_file(const std::string& path, double scale) {
    if (!(scale > 0.0) || !std::isfinite(scale)) {
        throw SpecError("add mesh: scale = " + std::to_string(scale) + "; accepted: finite, > 0 (file units to m)");
    }
    Assimp::Importer importer;
    // Triangulate polygons, join identical vertices, drop points and lines; no normals are read (the winding is).
    importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
    const aiScene* scene =
        importer.ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType);
    if (scene == nullptr) {
        throw SpecError("add mesh: cannot read '" + path + "' as STL or OBJ: " + importer.GetErrorString());
    }
    MeshFile out;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const aiMesh* mesh = scene->mMeshes[m];
        const auto base = static_cast<std::uint32_t>(out.vertices.size());
        for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
            const aiVector3D& p = mesh->mVertices[v];
            out.vertices.push_back({scale * p.x, scale * p.y, scale * p.z});
        }
        for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
            const aiFace& face = mesh->mFaces[f];
            if (face.mNumIndices != 3) continue;
            out.triangles.push_back({base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
        }
    }
    if (out.triangles.empty()) throw SpecError("add mesh: '" + path + "' has no triangles");
    return out;
}

}  // namespace hapticctl
