// SPDX-License-Identifier: Apache-2.0
// The client's subscriptions (docs/protocol.md, sections 3 and 6): states, events and contact events, and the
// unsolicited messages kept while a request waits for its reply (Client::keep_unsolicited).
#include "hapticd/client.hpp"

#include <chrono>

#include <nlohmann/json.hpp>

#include "client/message_json.hpp"

namespace hapticd::client {

namespace {

using nlohmann::json;

}  // namespace

void Client::subscribe(double rate_hz) { request("subscribe", json{{"rate_hz", rate_hz}}.dump()); }

void Client::unsubscribe() {
    request("unsubscribe", "");
    pending_states_.clear();
}

std::optional<StateSample> Client::next_state(double timeout_s) {
    if (!pending_states_.empty()) {
        const json j = json::parse(pending_states_.front());
        pending_states_.erase(pending_states_.begin());
        return state_from_json(j);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
        const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
        if (left <= 0.0) return std::nullopt;
        const auto raw = receive_raw(left);
        if (!raw) return std::nullopt;
        const json j = json::parse(*raw, nullptr, false);
        if (j.is_object() && j.value("type", std::string()) == "state") return state_from_json(j);
        keep_unsolicited(*raw, "Client::next_state");
    }
}

std::optional<StateSample> Client::latest_state(double timeout_s) {
    while (const auto raw = receive_raw(0.0)) keep_unsolicited(*raw, "Client::latest_state");
    if (!pending_states_.empty()) {
        const json j = json::parse(pending_states_.back());
        pending_states_.clear();
        return state_from_json(j);
    }
    return next_state(timeout_s);
}

bool Client::keep_unsolicited(const std::string& raw, const std::string& function) {
    const json j = json::parse(raw, nullptr, false);
    if (!j.is_object()) return false;
    const std::string t = j.value("type", std::string());
    if (t == "state") {
        pending_states_.push_back(raw);
        return false;
    }
    if (t == "expired") throw error_from_reply(function, j);
    if (t == "contact") {
        if (contacts_.size() >= contact_capacity_) {
            ++contacts_dropped_;
        } else {
            contacts_.push_back(contact_from_json(j));
        }
        return false;
    }
    if (t != "event") return false;
    if (events_.size() >= event_capacity_) {
        ++events_dropped_;
        return true;
    }
    Event e;
    e.code = j.value("code", std::string());
    e.message = j.value("message", std::string());
    if (const auto ids = j.find("object_ids"); ids != j.end() && ids->is_array()) {
        for (const auto& id : *ids) {
            if (id.is_number_unsigned() && id.get<std::uint64_t>() <= 0xffffffffULL)
                e.object_ids.push_back(id.get<std::uint32_t>());
        }
    }
    e.json = raw;
    events_.push_back(std::move(e));
    return true;
}

std::optional<Event> Client::poll_event() {
    while (events_.empty()) {
        const auto raw = receive_raw(0.0);
        if (!raw) break;
        keep_unsolicited(*raw, "Client::poll_event");
    }
    if (events_.empty()) return std::nullopt;
    Event e = std::move(events_.front());
    events_.pop_front();
    return e;
}

std::optional<Event> Client::next_event(double timeout_s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
        if (auto e = poll_event()) return e;
        const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
        if (left <= 0.0) return std::nullopt;
        const auto raw = receive_raw(left);
        if (!raw) return std::nullopt;
        keep_unsolicited(*raw, "Client::next_event");
    }
}

std::vector<std::uint32_t> Client::subscribe_contacts(const std::vector<std::uint32_t>& object_ids) {
    json body = json::object();
    if (!object_ids.empty()) body["object_ids"] = object_ids;
    const json r = json::parse(request("subscribe_contacts", body.dump()));
    contacts_.clear();  // the reply's contacts are where the events that follow continue from
    std::vector<std::uint32_t> in_contact;
    for (const auto& id : r.value("contacts", json::array())) {
        if (id.is_number_unsigned() && id.get<std::uint64_t>() <= 0xffffffffULL)
            in_contact.push_back(id.get<std::uint32_t>());
    }
    return in_contact;
}

void Client::unsubscribe_contacts() {
    request("unsubscribe_contacts", "");
    contacts_.clear();
}

std::optional<ContactEvent> Client::poll_contact() {
    while (contacts_.empty()) {
        const auto raw = receive_raw(0.0);
        if (!raw) break;
        keep_unsolicited(*raw, "Client::poll_contact");
    }
    if (contacts_.empty()) return std::nullopt;
    ContactEvent e = contacts_.front();
    contacts_.pop_front();
    return e;
}

std::optional<ContactEvent> Client::next_contact(double timeout_s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
        if (auto e = poll_contact()) return e;
        const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
        if (left <= 0.0) return std::nullopt;
        const auto raw = receive_raw(left);
        if (!raw) return std::nullopt;
        keep_unsolicited(*raw, "Client::next_contact");
    }
}

}  // namespace hapticd::client
