// SPDX-License-Identifier: Apache-2.0
#include "scene/safety.hpp"

namespace hapticd {

std::string_view to_string(Fault fault) noexcept {
    switch (fault) {
        case Fault::None: return "none";
        case Fault::Watchdog: return "watchdog";
        case Fault::NonFinite: return "non-finite value";
        case Fault::Device: return "device error";
    }
    return "unknown";
}

}  // namespace hapticd
