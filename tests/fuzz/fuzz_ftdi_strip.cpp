// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: FTDI status-byte stripping (src/devices/ftdi_protocol.*). Invariants: no
// out-of-bounds access (the output buffer is exactly as large as the input), the result equals a
// naive reference (drop the first 2 bytes of every 64-byte chunk), and the in-place (aliased) call
// gives the same bytes.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "devices/ftdi_protocol.hpp"

namespace ftdi = hapticd::ftdi;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::vector<std::uint8_t> expected;
    for (std::size_t at = 0; at < size; at += ftdi::kMaxPacket) {
        const std::size_t end = at + ftdi::kMaxPacket < size ? at + ftdi::kMaxPacket : size;
        for (std::size_t i = at + ftdi::kStatusBytes; i < end; ++i) expected.push_back(data[i]);
    }
    std::vector<std::uint8_t> out(size);
    const std::size_t n = ftdi::strip_ftdi_status(data, size, out.data());
    if (n != expected.size() || (n > 0 && std::memcmp(out.data(), expected.data(), n) != 0)) std::abort();
    std::vector<std::uint8_t> inplace(data, data + size);
    const std::size_t m = ftdi::strip_ftdi_status(inplace.data(), size, inplace.data());
    if (m != n || (m > 0 && std::memcmp(inplace.data(), expected.data(), m) != 0)) std::abort();
    // Baud encoding: any 32-bit rate is accepted without UB.
    if (size >= 4) {
        std::uint32_t baud = 0;
        std::memcpy(&baud, data, 4);
        (void)ftdi::baud_value(baud);
    }
    return 0;
}
