// SPDX-License-Identifier: Apache-2.0
// One line of text for a state sample (`hapticctl watch`):
//   tick 1234 t 1.234 s x [+1.000 +0.000 -0.250] mm v [...] mm/s F [+0.500 +0.000 +0.000] N contact {1,7} objects 2
//   overruns 0 fault none
// t is the loop's time, tick x period (s). Only the device's axes are shown; contact lists the ids of the
// objects in contact (StateSample::contacts(): the config walls, ids 1 .. n, then the clients' objects).
#pragma once

#include <cstddef>
#include <string>

#include "hapticd/client.hpp"

namespace hapticctl {

std::string state_line(const hapticd::client::StateSample& s, std::size_t axes, double period_s);

// "none", "device", "non_finite", "watchdog", "fatal_signal", "terminate" (docs/protocol.md, section 6), or the number.
std::string fault_name(std::uint32_t fault);

}  // namespace hapticctl
