// SPDX-License-Identifier: Apache-2.0
// Object resolution on the server thread (docs/protocol.md, section 5): a client's object description becomes
// what the loop renders (ObjectParams) and what the summed-gain checks add (its K and B matrices), after every
// check of that one object: its vectors on the device's axes, inside the workspace (server/object_limits.hpp),
// its gains (explicit, or a criterion's optimum for its mass), the device's stiffness and force limits and the
// exact stability verdict for every mass it acts with. An object id becomes the slot holding it, refused when
// the object is unknown or not the session's. No socket, no state: each call reads the configuration, the
// checker and the slot table it is given.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "hapticd/client.hpp"
#include "scene/scene_objects.hpp"
#include "server/object_limits.hpp"
#include "server/server.hpp"
#include "tuning/engagement_patterns.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd::server {

// A slot's drain_seq before the batch removing its object has entered a ring.
inline constexpr std::uint64_t kNotPushed = ~std::uint64_t{0};

// A checked object: what the loop renders and what the summed-gain check adds. A mesh object also owns its
// hierarchy here (params.mesh points into it): the slot table keeps it alive until the loop is done with it.
struct Resolved {
    ObjectParams params;
    Matrix3 K_matrix{};
    Matrix3 B_matrix{};
    std::shared_ptr<const mesh::MeshHierarchy> mesh;
};

// Why a request is refused: the protocol's code, the message naming the field and the accepted range, and
// for unstable_gains the largest stable K and the B interval that makes K stable (N s/m).
struct Refusal {
    client::ErrorCode code = client::ErrorCode::BadMessage;
    std::string message;
    std::optional<double> largest_stable_K = std::nullopt;
    std::optional<std::pair<double, double>> damping_needed = std::nullopt;
};

// The server's view of one of the loop's object slots.
struct ServerSlot {
    enum class State { Free, Used, Draining } state = State::Free;
    std::uint32_t id = 0;
    std::uint64_t owner = 0;  // session id
    std::optional<client::ObjectDescription> description;
    Resolved resolved;
    std::uint64_t drain_seq = kNotPushed;  // Draining: the commit_seq of the batch that removes it
};
using SlotTable = std::array<ServerSlot, kSceneObjectCapacity>;

// The config walls as terms of the checks (ids 1 .. n, as in `list`): unilateral ones engage conditionally,
// and two facing each other on one axis with disjoint solids are never engaged together.
[[nodiscard]] std::vector<SceneTerm> terms_of_config_walls(const std::vector<ConfigWallInfo>& config_walls);

// The config walls' gains (the daemon's, along their axes) added to K and B: K += K_w e e^T, B += B_w e e^T.
void add_config_walls(const std::vector<ConfigWallInfo>& config_walls, Matrix3& K, Matrix3& B);

// A slot's object as a term of the checks, in `role`.
[[nodiscard]] SceneTerm slot_term(const ServerSlot& slot, SceneTerm::Role role);

// Objects `session` holds (used, not ramping out: those are no longer the session's).
[[nodiscard]] std::size_t objects_held(const SlotTable& slots, std::uint64_t session);

// The slot holding object `object_id` for `session`, or the refusal: not_owner for a config wall (ids
// 1 .. config_walls) or another session's object, unknown_object for an id not in the scene.
struct SlotLookup {
    int slot = -1;
    std::optional<Refusal> refusal;
};
[[nodiscard]] SlotLookup owned_slot(const SlotTable& slots, std::uint32_t object_id, std::uint64_t session,
                                    std::size_t config_walls);

// The first free slot that `taken` (slots this batch already changes) leaves, or -1.
[[nodiscard]] int free_slot(const SlotTable& slots, const std::array<bool, kSceneObjectCapacity>& taken);

// A crease angle -> the found mesh's corner normals for it, counted against the mesh limits, or the refusal
// (server/mesh_store.hpp: shading()).
using ShadingLookup = std::function<std::variant<const mesh::ShadingNormals*, Refusal>(double crease_angle_deg)>;

// A mesh id of the committing session -> its built hierarchy, or the refusal (server/mesh_store.hpp: built()), and
// the way to its shading tables (empty: a shaded mesh object is refused).
struct MeshLookupResult {
    std::shared_ptr<const mesh::MeshHierarchy> hierarchy;
    std::optional<Refusal> refusal;
    ShadingLookup shading;
};
using MeshLookup = std::function<MeshLookupResult(std::uint32_t mesh)>;

// The masses a mesh object acts with, for every contact configuration: with P any orthogonal projector (the span
// of 1, 2 or 3 contact normals, or I), the gains K P, B P split in y = M^1/2 x into scalar loops of mass 1 / s,
// s the non-zero eigenvalues of M^-1/2 P M^-1/2, which lie in [1 / lambda_max(M), 1 / lambda_min(M)]: every mass
// of [lambda_min, lambda_max] can occur. The set check holds each mass m over [c_min m, c_max m]; masses
// lambda_min (c_max / c_min)^j, j = 0, 1, .., up to lambda_max (and lambda_max itself) make these intervals
// cover [c_min lambda_min, c_max lambda_max] without a gap. `eigen_masses`: masses_of(I) (M's eigenvalues).
[[nodiscard]] std::vector<double> mesh_masses(const std::vector<double>& eigen_masses, double scale_min,
                                              double scale_max);
// The same with force shading at crease angle theta_c (degrees, 0 .. 80; docs/mesh-rendering.md, "Force shading"):
// on one face the wall law along its normal is scaled by c = n_s . n_f in [cos theta_c, 1], and with one mass and
// b = k = 0 the loop m x'' = c F is the loop (m / c) x'' = F: the masses reach lambda_max / cos theta_c (its cosine
// less 1e-9: the normals' rounding is ~1e-16).
[[nodiscard]] std::vector<double> shaded_mesh_masses(const std::vector<double>& eigen_masses, double scale_min,
                                                     double scale_max, double crease_angle_deg);

// The criterion a client's gains name: gains.criterion parsed into hapticopt::Criterion (hapticopt::parse_criterion:
// exact, case-sensitive), the one place the server turns the wire's name into the type the checker takes;
// std::nullopt for explicit gains (no name) and for a name that is not a criterion (resolution refuses it:
// unknown_criterion).
[[nodiscard]] std::optional<hapticopt::Criterion> named_criterion(const client::Gains& gains);

// Checks and resolves object descriptions against the device of `config` (axes, workspace, period, delay,
// max_force) with `checker` (masses, stiffness limit, stability verdicts, the criteria's cached optima).
// Both must outlive the resolver.
class ObjectResolver {
  public:
    ObjectResolver(const ServerConfig& config, GainChecker& checker) : config_(config), checker_(checker) {}

    // `out` the resolved object (its params' id left 0), or the refusal naming the field (without the
    // "commit: ops[i]: " prefix the commit adds).
    // `meshes`: the committing session's meshes (a mesh object without it is refused).
    [[nodiscard]] std::optional<Refusal> resolve(const client::ObjectDescription& d, Resolved& out,
                                                 const MeshLookup* meshes = nullptr);

  private:
    [[nodiscard]] std::optional<Refusal> check_vector(const client::Vec3& v, const std::string& field, bool unit) const;
    [[nodiscard]] WorkspaceBox workspace() const;
    [[nodiscard]] std::optional<Refusal> check_stiffness_limit(double K, const std::string& what) const;
    [[nodiscard]] std::optional<Refusal> resolve_gains(const client::Gains& gains, const std::string& kind,
                                                       const std::vector<double>& masses, double& K, double& B);
    [[nodiscard]] std::optional<Refusal> resolve_plane(const client::Plane& plane, Resolved& out);
    [[nodiscard]] std::optional<Refusal> resolve_spring(const client::Spring& spring, Resolved& out);
    [[nodiscard]] std::optional<Refusal> resolve_field(const client::Field& field, Resolved& out);
    [[nodiscard]] std::optional<Refusal> resolve_mesh(const client::Mesh& m, Resolved& out, const MeshLookup* meshes);

    const ServerConfig& config_;
    GainChecker& checker_;
};

}  // namespace hapticd::server
