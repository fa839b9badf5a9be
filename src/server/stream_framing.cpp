// SPDX-License-Identifier: Apache-2.0
#include "server/stream_framing.hpp"

#include <sys/socket.h>

#include <cerrno>
#include <cstring>

namespace hapticd::server {

void LineFramer::append(std::string_view bytes) {
    if (start_ > 0 && start_ >= buffer_.size() / 2) {  // drop what was returned: amortised O(1) per byte
        buffer_.erase(0, start_);
        start_ = 0;
    }
    buffer_.append(bytes.data(), bytes.size());
}

bool LineFramer::has_frame() const noexcept {
    const std::size_t end = buffer_.find('\n', start_ + scanned_);
    if (end != std::string::npos) return true;
    return buffered() > max_frame_ + 1;
}

LineFramer::Next LineFramer::next() {
    for (;;) {
        const std::size_t end = buffer_.find('\n', start_ + scanned_);
        if (end == std::string::npos) {
            scanned_ = buffer_.size() - start_;
            if (scanned_ > max_frame_ + 1) return {Status::Oversized, {}};  // + 1: a '\r' before the '\n'
            return {Status::NeedMore, {}};
        }
        std::size_t length = end - start_;
        const std::size_t begin = start_;
        start_ = end + 1;
        scanned_ = 0;
        if (length > 0 && buffer_[begin + length - 1] == '\r') --length;
        if (length > max_frame_) return {Status::Oversized, {}};
        if (length == 0) continue;  // an empty line: nothing to answer
        return {Status::Frame, std::string_view(buffer_).substr(begin, length)};
    }
}

SendResult StreamOutbox::send_framed(int fd, std::string_view text) {
    // One send of message + '\n' when nothing waits; what the socket does not take is kept.
    pending_.erase(0, sent_);
    sent_ = 0;
    const std::size_t before = pending_.size();
    pending_.append(text.data(), text.size());
    pending_.push_back('\n');
    if (before > 0) return SendResult::Sent;  // behind earlier bytes: flush() sends it in order
    return flush(fd) == SendResult::Failed ? SendResult::Failed : SendResult::Sent;
}

SendResult StreamOutbox::send_reply(int fd, std::string_view text) {
    if (pending() + text.size() + 1 > kStreamPendingLimit) return SendResult::Full;
    return send_framed(fd, text);
}

SendResult StreamOutbox::send_if_idle(int fd, std::string_view text) {
    if (!idle()) {
        const SendResult r = flush(fd);
        if (r != SendResult::Sent) return r;
    }
    return send_framed(fd, text);
}

SendResult StreamOutbox::flush(int fd) {
    while (sent_ < pending_.size()) {
        const ssize_t n = ::send(fd, pending_.data() + sent_, pending_.size() - sent_, MSG_DONTWAIT | MSG_NOSIGNAL);
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno == EAGAIN || errno == EWOULDBLOCK ? SendResult::Full : SendResult::Failed;
        }
        sent_ += static_cast<std::size_t>(n);
    }
    pending_.clear();
    sent_ = 0;
    return SendResult::Sent;
}

}  // namespace hapticd::server
