// SPDX-License-Identifier: Apache-2.0
// The framing of the stream transport (docs/protocol.md section 1): over a SOCK_STREAM Unix socket (the one an
// OpenSSH forward reaches) each message is one compact JSON object followed by '\n'. LineFramer cuts received
// bytes into messages; StreamOutbox sends framed messages without ever blocking, keeping what the socket did not
// take (at most kStreamPendingLimit bytes) for the next round.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace hapticd::server {

enum class SendResult { Sent, Full, Failed };

// Bytes of framed replies a stream session may have waiting for room in its socket; a reply beyond it closes
// the session (slow_consumer), as a reply that does not fit in a SOCK_SEQPACKET socket does.
inline constexpr std::size_t kStreamPendingLimit = 262144;

// Cuts a byte stream into '\n'-terminated frames of at most `max_frame` bytes (the '\n' not counted, a '\r'
// before it removed). Empty lines are skipped. Memory: at most max_frame + one append's bytes.
class LineFramer {
  public:
    explicit LineFramer(std::size_t max_frame) : max_frame_(max_frame) {}

    void append(std::string_view bytes);

    enum class Status { Frame, NeedMore, Oversized };
    struct Next {
        Status status = Status::NeedMore;
        std::string_view frame;  // Frame: the message, valid until the next append or next()
    };
    // The next complete frame; Oversized when max_frame bytes have come without a '\n' (the stream cannot be
    // resynchronised: the caller closes it); NeedMore when the buffered bytes end inside a frame.
    [[nodiscard]] Next next();
    // Bytes received and not yet returned as frames.
    [[nodiscard]] std::size_t buffered() const noexcept { return buffer_.size() - start_; }
    // True when a '\n' or more than max_frame + 1 bytes wait: next() may have a frame (or an overrun) to return,
    // or only empty lines to skip; false once next() has said NeedMore and nothing was appended.
    [[nodiscard]] bool has_frame() const noexcept;

  private:
    std::size_t max_frame_;
    std::string buffer_;
    std::size_t start_ = 0;    // first byte not yet returned
    std::size_t scanned_ = 0;  // bytes from start_ known to hold no '\n'
};

// What the server sends on one stream connection: message + '\n', never blocking (MSG_DONTWAIT).
class StreamOutbox {
  public:
    // A reply: sent now, or what the socket does not take kept (Full when that would exceed
    // kStreamPendingLimit: the caller closes the session).
    [[nodiscard]] SendResult send_reply(int fd, std::string_view text);
    // A state or contact message: sent only when nothing waits (else Full: the caller drops or queues it); a
    // partly sent one is completed by flush().
    [[nodiscard]] SendResult send_if_idle(int fd, std::string_view text);
    // Sends what waits, as far as the socket takes it; Failed on a socket error (errno kept).
    [[nodiscard]] SendResult flush(int fd);
    [[nodiscard]] bool idle() const noexcept { return pending_.size() == sent_; }
    [[nodiscard]] std::size_t pending() const noexcept { return pending_.size() - sent_; }

  private:
    SendResult send_framed(int fd, std::string_view text);
    std::string pending_;
    std::size_t sent_ = 0;  // bytes of pending_ already sent
};

}  // namespace hapticd::server
