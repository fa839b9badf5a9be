// SPDX-License-Identifier: Apache-2.0
#include "state_line.hpp"

#include <cstdio>

namespace hapticctl {

namespace {

void append_vector(std::string& out, const char* name, const hapticd::client::Vec3& v, std::size_t axes, double scale,
                   const char* unit) {
    out += ' ';
    out += name;
    out += " [";
    char buf[32];
    for (std::size_t i = 0; i < axes && i < 3; ++i) {
        std::snprintf(buf, sizeof buf, i == 0 ? "%+.3f" : " %+.3f", v[i] * scale);
        out += buf;
    }
    out += "] ";
    out += unit;
}

}  // namespace

std::string fault_name(std::uint32_t fault) {
    return hapticd::is_state_fault(fault) ? hapticd::to_string(static_cast<hapticd::StateFault>(fault))
                                          : std::to_string(fault);
}

std::string state_line(const hapticd::client::StateSample& s, std::size_t axes, double period_s) {
    std::string out;
    char buf[64];
    std::snprintf(buf, sizeof buf, "tick %llu t %.3f s", static_cast<unsigned long long>(s.tick),
                  static_cast<double>(s.tick) * period_s);
    out += buf;
    append_vector(out, "x", s.position, axes, 1e3, "mm");
    append_vector(out, "v", s.velocity, axes, 1e3, "mm/s");
    append_vector(out, "F", s.force, axes, 1.0, "N");
    out += " contact {";
    bool first = true;
    for (const std::uint32_t id : s.contacts()) {
        if (!first) out += ',';
        out += std::to_string(id);
        first = false;
    }
    out += "} objects " + std::to_string(s.objects) + " overruns " + std::to_string(s.overruns) + " fault " +
           fault_name(s.fault);
    return out;
}

}  // namespace hapticctl
