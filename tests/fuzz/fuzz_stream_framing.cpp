// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the stream transport's framing (src/server/stream_framing.*, docs/protocol.md section 1) on
// arbitrary bytes. The first two bytes choose the largest frame (1 .. 512, so that oversized frames are common)
// and the cut of the rest into appends (1 .. 256 bytes each); the rest is the stream. Invariants: no crash; the
// frames LineFramer returns, and where it says Oversized, are those of a reference written independently here
// (split the whole stream at every '\n', drop one '\r' before it, skip empty lines, stop at the first line
// longer than the limit or at a tail without '\n' already longer than limit + 1); every frame holds no '\n' and
// is at most the limit; has_frame() is true whenever next() has a frame or an overrun, false once next() said NeedMore;
// the bytes kept never exceed the limit + one append.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "server/stream_framing.hpp"

namespace {

void check(bool ok) {
    if (!ok) std::abort();
}

struct Expected {
    std::vector<std::string> frames;
    bool oversized = false;
};

Expected reference(std::string_view stream, std::size_t limit) {
    Expected e;
    std::size_t start = 0;
    for (;;) {
        const std::size_t end = stream.find('\n', start);
        if (end == std::string_view::npos) {
            e.oversized = stream.size() - start > limit + 1;
            return e;
        }
        std::string_view line = stream.substr(start, end - start);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (line.size() > limit) {
            e.oversized = true;
            return e;
        }
        if (!line.empty()) e.frames.emplace_back(line);
        start = end + 1;
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) return 0;
    const std::size_t limit = 1 + (static_cast<std::size_t>(data[0]) * 2 + (data[1] & 1U));
    const std::size_t cut = 1 + (data[1] >> 1U) * 2;
    const std::string_view stream(reinterpret_cast<const char*>(data + 2), size - 2);
    const Expected expected = reference(stream, limit);

    hapticd::server::LineFramer framer(limit);
    std::vector<std::string> got;
    bool oversized = false;
    for (std::size_t at = 0; at < stream.size() && !oversized;) {
        const std::size_t n = std::min(cut, stream.size() - at);
        framer.append(stream.substr(at, n));
        at += n;
        for (;;) {
            const bool has = framer.has_frame();
            const auto next = framer.next();
            if (next.status != hapticd::server::LineFramer::Status::NeedMore) check(has);
            if (next.status == hapticd::server::LineFramer::Status::NeedMore) {
                check(!framer.has_frame());
                break;
            }
            if (next.status == hapticd::server::LineFramer::Status::Oversized) {
                oversized = true;
                break;
            }
            check(!next.frame.empty() && next.frame.size() <= limit);
            check(next.frame.find('\n') == std::string_view::npos);
            got.emplace_back(next.frame);
        }
        if (!oversized) check(framer.buffered() <= limit + 1 + cut);
    }
    check(oversized == expected.oversized);
    check(got == expected.frames);
    return 0;
}
