// SPDX-License-Identifier: Apache-2.0
// First-run safety for real devices: until `hapticd check-device` has measured that the device's force
// acts along its position axes (sign +1 on every axis, after the profile's `force_sign`), hapticd caps
// the force at kFirstRunMaxForce. The confirmation is a small file per profile in hapticd's state
// directory: $HAPTICD_STATE_DIR, else $XDG_STATE_HOME/hapticd, else $HOME/.local/state/hapticd.
#pragma once

#include <filesystem>
#include <string>

namespace hapticd {

inline constexpr double kFirstRunMaxForce = 1.0;  // N (N m for rotary devices)

std::filesystem::path hapticd_state_directory();
std::filesystem::path force_sign_confirmation_file(const std::string& profile_name);
[[nodiscard]] bool force_sign_confirmed(const std::string& profile_name);
// Writes the confirmation (`details`: what was measured); false with `error` on an I/O failure.
bool record_force_sign_confirmed(const std::string& profile_name, const std::string& details, std::string& error);

}  // namespace hapticd
