// SPDX-License-Identifier: Apache-2.0
#include "config/hand_schedule.hpp"

#include <charconv>
#include <cmath>
#include <stdexcept>

namespace hapticd {

std::string_view to_string(HandEventKind kind) noexcept {
    switch (kind) {
        case HandEventKind::Release:
            return "release";
        case HandEventKind::Grip:
            return "grip";
        case HandEventKind::Arm:
            return "arm";
    }
    return "unknown";
}

namespace {

constexpr const char* kForm =
    "accepted: comma-separated events release@T, grip@T, arm@T:k=K:b=B (k and/or b), T in s from the start, "
    "strictly increasing, e.g. 'release@2.0,grip@4.0'";

std::string_view trim(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
    return s;
}

std::string shortest(double v) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

// The whole of `s` as a finite number; nullopt otherwise.
std::optional<double> number(std::string_view s) {
    double v = 0.0;
    const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
    if (s.empty() || r.ec != std::errc() || r.ptr != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
    return v;
}

[[noreturn]] void refuse(std::string_view text, std::string_view event, const std::string& what,
                         const std::string& accepted) {
    throw std::invalid_argument("hand-schedule = '" + std::string(text) + "' is invalid: event '" + std::string(event) +
                                "': " + what + "; " + accepted);
}

}  // namespace

std::vector<HandEvent> parse_hand_schedule(std::string_view text) {
    std::vector<HandEvent> events;
    if (trim(text).empty()) return events;
    bool held = true;
    std::size_t begin = 0;
    while (begin <= text.size()) {
        const std::size_t comma = std::min(text.find(',', begin), text.size());
        const std::string_view item = trim(text.substr(begin, comma - begin));
        begin = comma + 1;
        const std::size_t at = item.find('@');
        if (at == std::string_view::npos) refuse(text, item, "no '@' before its time", kForm);
        const std::string_view name = trim(item.substr(0, at));
        HandEvent e;
        if (name == "release") {
            e.kind = HandEventKind::Release;
        } else if (name == "grip") {
            e.kind = HandEventKind::Grip;
        } else if (name == "arm") {
            e.kind = HandEventKind::Arm;
        } else {
            refuse(text, item, "unknown event '" + std::string(name) + "'", kForm);
        }
        std::string_view rest = item.substr(at + 1);
        const std::size_t colon = std::min(rest.find(':'), rest.size());
        const std::string_view time_text = trim(rest.substr(0, colon));
        const auto time = number(time_text);
        if (!time || *time < 0.0 || *time > kHandScheduleMaxTime) {
            refuse(text, item, "time '" + std::string(time_text) + "'", "accepted range: 0 .. 1e7 s from the start");
        }
        e.time = *time;
        if (!events.empty() && !(e.time > events.back().time)) {
            refuse(text, item,
                   "time " + shortest(e.time) + " s is not after the previous event's (" +
                       shortest(events.back().time) + " s)",
                   "accepted: strictly increasing times");
        }
        rest = colon < rest.size() ? rest.substr(colon + 1) : std::string_view{};
        if (e.kind != HandEventKind::Arm && !trim(rest).empty()) {
            refuse(text, item, "'" + std::string(rest) + "' after the time", "only arm@T takes k=K and b=B");
        }
        while (e.kind == HandEventKind::Arm && !rest.empty()) {
            const std::size_t next = std::min(rest.find(':'), rest.size());
            const std::string_view pair = trim(rest.substr(0, next));
            rest = next < rest.size() ? rest.substr(next + 1) : std::string_view{};
            const std::size_t eq = pair.find('=');
            const std::string_view key = trim(pair.substr(0, std::min(eq, pair.size())));
            const double value = eq == std::string_view::npos ? -1.0 : number(trim(pair.substr(eq + 1))).value_or(-1.0);
            if (key == "k") {
                if (value < 0.0 || value > kHandScheduleMaxStiffness)
                    refuse(text, item, "k_H '" + std::string(pair) + "'", "accepted range: k=0 .. 1e9 N/m");
                e.stiffness = value;
            } else if (key == "b") {
                if (value < 0.0 || value > kHandScheduleMaxDamping)
                    refuse(text, item, "b_H '" + std::string(pair) + "'", "accepted range: b=0 .. 1e6 N s/m");
                e.damping = value;
            } else {
                refuse(text, item, "unknown parameter '" + std::string(pair) + "'",
                       "accepted: arm@T:k=K:b=B (k and/or b)");
            }
        }
        if (e.kind == HandEventKind::Arm && !e.stiffness && !e.damping) {
            refuse(text, item, "no k=K or b=B", "accepted: arm@T:k=K:b=B (k and/or b)");
        }
        if (e.kind == HandEventKind::Release && !held) refuse(text, item, "the hand is already off the handle", kForm);
        if (e.kind == HandEventKind::Grip && held) {
            refuse(text, item, "the hand already holds the handle (every run starts with it held)", kForm);
        }
        if (e.kind == HandEventKind::Release) held = false;
        if (e.kind == HandEventKind::Grip) held = true;
        events.push_back(e);
        if (comma == text.size()) break;
    }
    return events;
}

std::string describe(const std::vector<HandEvent>& events) {
    std::string s;
    for (const HandEvent& e : events) {
        if (!s.empty()) s += ',';
        s += std::string(to_string(e.kind)) + "@" + shortest(e.time);
        if (e.stiffness) s += ":k=" + shortest(*e.stiffness);
        if (e.damping) s += ":b=" + shortest(*e.damping);
    }
    return s;
}

}  // namespace hapticd
