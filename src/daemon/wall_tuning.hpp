// SPDX-License-Identifier: Apache-2.0
// hapticd's tuning step (run.cpp): every wall of the configuration parsed, tuned for its
// criterion (or its explicit gains checked), certified over the profile's plant set, and --robust's box.
#pragma once

#include <optional>
#include <vector>

#include "config/options.hpp"
#include "identification/identification_run.hpp"
#include "scene/scene.hpp"
#include "scene/wall.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

struct ResolvedWall {
    WallSpec spec;
    WallGeometry geometry;
    TuningResult tuning;
};

// Each wall of the options parsed, tuned for its criterion (each criterion once per axis key) or its explicit gains
// checked, certified over the profile's plant set (a criterion's optimum derated when it is not stable over it),
// its encoder effects predicted, checked against the profile's max_stiffness. Throws StartupError naming the wall.
std::vector<ResolvedWall> resolve_walls(const Options& o, const DeviceProfile& p, const TuningPlant& plant,
                                        const std::optional<TuningBox>& box);

// The box of --robust: the identified values +- 3 standard errors after an identification, else the profile's
// *_range keys (a missing key: the nominal value, exact). Physical bounds are kept (mass > 0, b, k, delay >= 0).
TuningBox robust_box(const Options& o, const DeviceProfile& p, const std::optional<IdentificationStage>& ident,
                     double period);

}  // namespace hapticd
