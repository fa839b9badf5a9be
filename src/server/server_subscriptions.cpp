// SPDX-License-Identifier: Apache-2.0
// The state and contact subscriptions of the sessions (Server::Impl, server_impl.hpp): states at each
// session's rate, the loop's contact records queued and sent to the subscribers, the stream
// sockets' outboxes flushed.
#include "server/server_impl.hpp"

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "server/replies.hpp"

namespace hapticd {

void Server::Impl::send_states(Clock::time_point now) {
    bool have = false;
    for (auto& [sid, s] : sessions) {
        // A state never overtakes a contact event: while contact messages wait for room, states wait too.
        if (s.closed || !s.subscribed || now < s.next_state || !s.contact_queue.empty()) continue;
        if (!have) {
            if (!state.read(snapshot)) return;  // no consistent tick now: the states go out on a later pass
            have = true;
        }
        s.next_state += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / s.rate_hz));
        if (s.next_state < now) s.next_state = now;  // never send bursts to catch up
        const std::string text = server::state_message(snapshot, s.dropped).dump();
        switch (s.stream ? s.outbox.send_if_idle(s.fd, text) : server::send_message(s.fd, text)) {
            case server::SendResult::Sent:
                break;
            case server::SendResult::Full:
                ++s.dropped;
                count(&ServerCounters::states_dropped);
                break;
            case server::SendResult::Failed:
                close_session(s, std::string("send failed: ") + std::strerror(errno));
                break;
        }
    }
}

// Takes every record the loop has handed over (at most a ring's worth), in tick order, and queues one
// message per record for each contact subscriber whose filter admits the object; then sends what fits.
// Records the loop could not hand over (lost_before rose) count as dropped for every subscriber.
void Server::Impl::drain_contacts() {
    if (contact_ring == nullptr) return;
    ContactRecord r;
    std::uint64_t lost_total = 0, dropped_total = 0;
    for (std::size_t n = 0; n < contact_ring->capacity() && contact_ring->try_pop(r); ++n) {
        const std::uint64_t lost = r.lost_before - contact_lost_seen;
        contact_lost_seen = r.lost_before;
        lost_total += lost;
        const auto it = std::lower_bound(in_contact.begin(), in_contact.end(), r.object_id);
        const bool present = it != in_contact.end() && *it == r.object_id;
        if (r.begin && !present) in_contact.insert(it, r.object_id);
        if (!r.begin && present) in_contact.erase(it);
        std::optional<json> message;
        for (auto& [sid, s] : sessions) {
            if (s.closed || !s.contacts) continue;
            s.contact_dropped += lost;
            if (s.contact_filter &&
                std::find(s.contact_filter->begin(), s.contact_filter->end(), r.object_id) == s.contact_filter->end()) {
                continue;
            }
            if (s.contact_queue.size() >= server::kContactQueueCapacity) {
                ++s.contact_dropped;
                ++dropped_total;
                continue;
            }
            if (!message) message = server::contact_message(r);
            (*message)["dropped"] = s.contact_dropped;
            s.contact_queue.push_back(message->dump());
        }
    }
    if (lost_total != 0 || dropped_total != 0) {
        std::lock_guard<std::mutex> lock(counters_mutex);
        counters.contacts_lost += lost_total;
        counters.contacts_dropped += dropped_total;
    }
    for (auto& [sid, s] : sessions) flush_contacts(s);
}

// Sends a session's waiting contact messages in order until its socket is full (the rest wait for the
// next round); never blocks.
void Server::Impl::flush_contacts(Session& s) {
    while (!s.closed && !s.contact_queue.empty()) {
        const std::string& text = s.contact_queue.front();
        switch (s.stream ? s.outbox.send_if_idle(s.fd, text) : server::send_message(s.fd, text)) {
            case server::SendResult::Sent:
                s.contact_queue.pop_front();
                break;
            case server::SendResult::Full:
                return;
            case server::SendResult::Failed:
                close_session(s, std::string("send failed: ") + std::strerror(errno));
                return;
        }
    }
}

void Server::Impl::subscribe_contacts(Session& s, std::uint64_t id, const server::SubscribeContactsRequest& req) {
    drain_contacts();  // what happened before this reply goes to the earlier subscribers only
    s.contacts = true;
    s.contact_filter = req.object_ids;
    s.contact_queue.clear();
    s.contact_dropped = 0;
    json ids = json::array();
    for (const std::uint32_t oid : in_contact) {
        if (!s.contact_filter ||
            std::find(s.contact_filter->begin(), s.contact_filter->end(), oid) != s.contact_filter->end()) {
            ids.push_back(oid);
        }
    }
    json ok = server::ok_reply(id);
    ok["contacts"] = ids;
    send_reply(s, ok);
}

// At the stop, after the loop's last tick: its records (the `end` of every contact still in progress,
// ContactDetector::end_all) go to the subscribers, each session's queue sent as its socket takes it for up
// to kFinalContactFlush; what a session that does not read leaves then is lost with the session.
void Server::Impl::final_contacts() {
    drain_contacts();
    const auto until = Clock::now() + server::kFinalContactFlush;
    std::vector<pollfd> fds;
    while (Clock::now() < until) {
        fds.clear();
        for (auto& [sid, s] : sessions) {
            if (!s.closed && !s.contact_queue.empty()) fds.push_back({s.fd, POLLOUT, 0});
        }
        if (fds.empty()) return;
        if (::poll(fds.data(), fds.size(), 10) < 0 && errno != EINTR) return;
        for (auto& [sid, s] : sessions) flush_contacts(s);
    }
}

// The replies, states and contact messages a stream socket did not take yet, as far as it takes them now.
void Server::Impl::flush_stream_outboxes() {
    for (auto& [sid, s] : sessions) {
        if (s.closed || !s.stream || s.outbox.idle()) continue;
        if (s.outbox.flush(s.fd) == server::SendResult::Failed)
            close_session(s, std::string("send failed: ") + std::strerror(errno));
    }
}

}  // namespace hapticd
