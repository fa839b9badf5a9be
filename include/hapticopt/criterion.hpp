// SPDX-License-Identifier: Apache-2.0
// The optimisation criteria of Tables III and IV (Hulin et al. 2011, Sect. IV; docs/methods.md).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hapticopt {

enum class Criterion {
    AlphaMax,   ///< "amax": largest stable alpha and its beta
    Overshoot,  ///< "OV": largest alpha for which some beta gives no overshoot
    CE0,        ///< "CE0": global minimum of C_E0 (eq. 6)
    CE1,        ///< "CE1": eq. 7
    CE2,        ///< "CE2": eq. 8
    CE0_OV,     ///< "CE0+OV": largest alpha on the C_E0 optimal curve without overshoot
    CE1_OV,     ///< "CE1+OV"
    CE2_OV,     ///< "CE2+OV"
};

inline constexpr std::array<Criterion, 8> kAllCriteria = {Criterion::AlphaMax, Criterion::Overshoot, Criterion::CE0,
                                                          Criterion::CE1,      Criterion::CE2,       Criterion::CE0_OV,
                                                          Criterion::CE1_OV,   Criterion::CE2_OV};

inline constexpr std::string_view to_string(Criterion c) {
    switch (c) {
        case Criterion::AlphaMax:
            return "amax";
        case Criterion::Overshoot:
            return "OV";
        case Criterion::CE0:
            return "CE0";
        case Criterion::CE1:
            return "CE1";
        case Criterion::CE2:
            return "CE2";
        case Criterion::CE0_OV:
            return "CE0+OV";
        case Criterion::CE1_OV:
            return "CE1+OV";
        case Criterion::CE2_OV:
            return "CE2+OV";
    }
    return "?";
}

/// Parses the names printed by to_string (exact, case-sensitive).
inline std::optional<Criterion> parse_criterion(std::string_view name) {
    for (const Criterion c : kAllCriteria) {
        if (to_string(c) == name) return c;
    }
    return std::nullopt;
}

/// The energy criteria without the overshoot condition: CE0, CE1, CE2 (each one cost surface).
inline constexpr std::array<Criterion, 3> kEnergyCriteria = {Criterion::CE0, Criterion::CE1, Criterion::CE2};

/// The energy criterion index 0, 1, 2 behind CEx and CEx+OV; nullopt for amax and OV.
inline constexpr std::optional<int> energy_index(Criterion c) {
    switch (c) {
        case Criterion::CE0:
        case Criterion::CE0_OV:
            return 0;
        case Criterion::CE1:
        case Criterion::CE1_OV:
            return 1;
        case Criterion::CE2:
        case Criterion::CE2_OV:
            return 2;
        default:
            return std::nullopt;
    }
}

inline constexpr bool requires_no_overshoot(Criterion c) {
    return c == Criterion::Overshoot || c == Criterion::CE0_OV || c == Criterion::CE1_OV || c == Criterion::CE2_OV;
}

/// The collision (impulse-response) criteria C_I0, C_I1, C_I2 (impulse_costs.hpp): a separate enum
/// so that the eight step criteria of Tables III and IV (kAllCriteria, the switches in optimum.hpp,
/// the CLI and the daemon) stay exactly as they are.
enum class ImpulseCriterion {
    CI0,  ///< "CI0": global minimum of C_I0 (impulse_costs.hpp)
    CI1,  ///< "CI1"
    CI2,  ///< "CI2"
};

inline constexpr std::array<ImpulseCriterion, 3> kAllImpulseCriteria = {ImpulseCriterion::CI0, ImpulseCriterion::CI1,
                                                                        ImpulseCriterion::CI2};

inline constexpr std::string_view to_string(ImpulseCriterion c) {
    switch (c) {
        case ImpulseCriterion::CI0:
            return "CI0";
        case ImpulseCriterion::CI1:
            return "CI1";
        case ImpulseCriterion::CI2:
            return "CI2";
    }
    return "?";
}

/// Parses "CI0", "CI1", "CI2" (exact, case-sensitive).
inline std::optional<ImpulseCriterion> parse_impulse_criterion(std::string_view name) {
    for (const ImpulseCriterion c : kAllImpulseCriteria) {
        if (to_string(c) == name) return c;
    }
    return std::nullopt;
}

/// The names of `criteria` (to_string of each, Criterion or ImpulseCriterion), in order: the lists a
/// command line or an error message accepts.
template <typename Criteria>
std::vector<std::string> criterion_names(const Criteria& criteria) {
    std::vector<std::string> out;
    for (const auto c : criteria) out.emplace_back(to_string(c));
    return out;
}

/// `names` joined by ", " (for "accepted: ..." in messages and help texts).
inline std::string joined_names(const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
    return out;
}

/// The energy index 0, 1, 2 of C_I0..2.
inline constexpr int energy_index(ImpulseCriterion c) {
    return c == ImpulseCriterion::CI0 ? 0 : c == ImpulseCriterion::CI1 ? 1 : 2;
}

}  // namespace hapticopt
