// SPDX-License-Identifier: Apache-2.0
// Contact events (docs/protocol.md, section 6, "Contact events") against the state stream of the same
// session, with real processes: hapticd --serve on the shipped default profile (config/devices/sim.toml, the
// simulated hand at rest at x = 0) at its real 1 kHz rate. Nothing here depends on timing: every step waits
// (up to 30 s) for a condition that holds for as long as the test does not change the scene, and every check
// compares the events with the state samples the session happened to receive.
//  * A plane the hand rests on (normal -x, offset 5 mm around the handle): a begin with the plane's id; moved
//    away (offset -10 mm): an end; moved back: a begin; removed: an end (at the latest the tick its ramp-out frees
//    the slot).
//  * A config wall at x = 2 mm and a field pushing the handle +x by 1 N into it (the hand's spring, 200 N/m,
//    would hold it at 5 mm): a begin of the field; the handle hits wall 1 (it may bounce: begins and ends)
//    and rests on it; the field removed: the field's end and the wall's last end.
// Each step waits for a state sample, newer than the last event, that shows the step's contact. In both:
// per object, begin and end alternate with rising ticks; every state sample's contacts are exactly
// the objects whose last event up to that sample's tick is a begin; a sample of an event's tick has the
// event's position and force; no event is dropped. Plus a malformed subscribe_contacts gets an error reply, and
// a daemon that stops sends the `end` of every contact in progress.
#include <cstdio>
#include <cstdlib>
#include <map>

#include "common/test_paths.hpp"
#include "server_fixture.hpp"

namespace hapticd::server_test {
namespace {

// The loop at normal priority (--rt-priority 0) unless `rt_priority` says otherwise.
std::vector<std::string> contact_daemon_args(const Names& n, const std::vector<std::string>& walls,
                                             const std::string& rt_priority = "0") {
    std::vector<std::string> a{"--config",  "",
                               "--device",  HAPTICD_SERVER_TEST_DIR + "/../../config/devices/sim.toml",
                               "--serve",   "--serve-socket",
                               n.socket,    "--serve-shm",
                               n.shm,       "--rt-priority",
                               rt_priority, "--mlock",
                               "false"};
    a.insert(a.end(), walls.begin(), walls.end());
    return a;
}

// What one session received: its state samples and its contact events, in arrival order.
struct Received {
    std::vector<cl::StateSample> states;
    std::vector<cl::ContactEvent> contacts;
};

// Reads the session (states at the subscribed rate, contact events as they come) until pred(received) or
// 30 s; returns whether pred held.
template <class Pred>
bool pump_until(cl::Client& c, Received& r, Pred pred) {
    const double end = monotonic_s() + 30.0;
    while (monotonic_s() < end) {
        if (auto s = c.next_state(0.05)) r.states.push_back(*s);
        while (auto e = c.poll_contact()) r.contacts.push_back(*e);
        if (pred(r)) return true;
    }
    return false;
}

bool state_in_contact(const cl::StateSample& s, std::uint32_t id) {
    const auto ids = s.contacts();
    return std::find(ids.begin(), ids.end(), id) != ids.end();
}

// Reads until the newest state sample, of a tick after every event received so far, satisfies pred.
template <class Pred>
bool wait_sample(cl::Client& c, Received& r, Pred pred) {
    return pump_until(c, r, [&](const Received& x) {
        const std::uint64_t after = x.contacts.empty() ? 0 : x.contacts.back().tick;
        return !x.states.empty() && x.states.back().tick > after && pred(x.states.back());
    });
}

// The events of every tick up to a sample's are guaranteed only once the next sample has arrived (the server
// sends a round's events before its state; the loop may publish a tick's state before its events reach the
// server): one more sample before the events are counted.
bool wait_for_the_next_sample(cl::Client& c, Received& r) {
    const std::uint64_t last = r.states.empty() ? 0 : r.states.back().tick;
    return wait_sample(c, r, [&](const cl::StateSample& s) { return s.tick > last; });
}

std::size_t count_events(const Received& r, std::uint32_t id, cl::ContactEvent::Kind kind) {
    std::size_t k = 0;
    for (const auto& e : r.contacts) k += e.object_id == id && e.kind == kind ? 1U : 0U;
    return k;
}

// The checks shared by both tests: alternation, the state samples against the events, nothing dropped.
// Returns how many samples saw each object in contact (the comparison is not vacuous when > 0).
std::map<std::uint32_t, std::size_t> check_against_states(const Received& r,
                                                          const std::vector<std::uint32_t>& initial) {
    std::map<std::uint32_t, std::vector<const cl::ContactEvent*>> by_object;
    std::uint64_t last_tick = 0;
    for (const auto& e : r.contacts) {
        EXPECT_EQ(e.dropped, 0U) << "object " << e.object_id << " tick " << e.tick;
        EXPECT_GE(e.tick, last_tick) << "events out of tick order";
        last_tick = e.tick;
        by_object[e.object_id].push_back(&e);
    }
    for (const auto& [id, events] : by_object) {
        bool in = std::find(initial.begin(), initial.end(), id) != initial.end();
        for (const auto* e : events) {
            EXPECT_EQ(e->kind == cl::ContactEvent::Kind::Begin, !in)
                << "object " << id << " tick " << e->tick << ": begin and end must alternate";
            in = !in;
        }
    }
    std::map<std::uint32_t, std::size_t> seen_in;
    std::size_t same_tick = 0;
    // Every event of a tick up to a sample's arrives before the next sample (the server sends a round's
    // events before its state, and a state waits while events wait): the last sample is left out.
    for (std::size_t i = 0; i + 1 < r.states.size(); ++i) {
        const cl::StateSample& s = r.states[i];
        if (s.time_s == 0.0) continue;  // sent before the loop's first tick: no tick published yet
        for (const auto& [id, events] : by_object) {
            bool in = std::find(initial.begin(), initial.end(), id) != initial.end();
            for (const auto* e : events) {
                if (e->tick <= s.tick) in = e->kind == cl::ContactEvent::Kind::Begin;
                if (e->tick == s.tick) {
                    ++same_tick;
                    for (std::size_t a = 0; a < 3; ++a) {
                        EXPECT_EQ(e->position[a], s.position[a]) << "object " << id << " tick " << s.tick;
                        EXPECT_EQ(e->force[a], s.force[a]) << "object " << id << " tick " << s.tick;
                    }
                    EXPECT_EQ(e->time_s, s.time_s);
                }
            }
            EXPECT_EQ(state_in_contact(s, id), in) << "object " << id << " at the state's tick " << s.tick;
            if (in) ++seen_in[id];
        }
    }
    if (std::getenv("CONTACTS_DUMP") != nullptr) {  // diagnosis: every event and sample on stdout
        for (const auto& e : r.contacts)
            std::printf("event %u %s tick %llu t %.6f x %.6g f %.6g\n", e.object_id,
                        e.kind == cl::ContactEvent::Kind::Begin ? "begin" : "end", (unsigned long long)e.tick, e.time_s,
                        e.position[0], e.force[0]);
        for (const auto& s : r.states)
            std::printf("state tick %llu t %.6f x %.6g n %zu\n", (unsigned long long)s.tick, s.time_s, s.position[0],
                        s.contacts().size());
    }
    std::printf("[ contacts ] %zu events, %zu state samples, %zu samples of an event's tick\n", r.contacts.size(),
                r.states.size(), same_tick);
    return seen_in;
}

TEST(ContactEvents, APlaneTheHandRestsOnBeginsAndEndsAsTheStateStreamSays) {
    const Names n = names("contacts_plane");
    Child daemon(HAPTICD_BINARY, contact_daemon_args(n, {"--no-walls"}), "contacts_plane_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    cl::Client c = cl::Client::connect({.socket_path = n.socket, .client_name = "contacts", .timeout_s = 30.0});
    const std::vector<std::uint32_t> initial = c.subscribe_contacts();
    EXPECT_TRUE(initial.empty());
    c.subscribe(1000.0);
    Received r;
    const cl::Plane near{.normal = {-1, 0, 0}, .offset = 0.005, .gains = cl::Gains::by_criterion("CE2")};
    const cl::Plane away{.normal = {-1, 0, 0}, .offset = -0.01, .gains = cl::Gains::by_criterion("CE2")};
    const std::uint32_t id = c.commit(cl::Batch().add(near)).object_ids.at(0);
    using K = cl::ContactEvent::Kind;
    ASSERT_TRUE(wait_sample(c, r, [&](const cl::StateSample& s) { return state_in_contact(s, id); }))
        << "never in contact";
    c.commit(cl::Batch().modify(id, away));
    ASSERT_TRUE(wait_sample(c, r, [&](const cl::StateSample& s) { return !state_in_contact(s, id); }))
        << "still in contact after moving away";
    c.commit(cl::Batch().modify(id, near));
    ASSERT_TRUE(wait_sample(c, r, [&](const cl::StateSample& s) { return state_in_contact(s, id); }))
        << "no contact after moving back";
    c.commit(cl::Batch().remove(id));
    ASSERT_TRUE(wait_sample(c, r, [&](const cl::StateSample& s) { return !state_in_contact(s, id) && s.objects == 0; }))
        << "the plane is not gone";
    ASSERT_TRUE(wait_for_the_next_sample(c, r));
    EXPECT_GE(count_events(r, id, K::Begin), 2U);
    EXPECT_GE(count_events(r, id, K::End), 2U);
    const auto seen = check_against_states(r, initial);
    EXPECT_GT(seen.count(id) != 0 ? seen.at(id) : 0U, 0U);
    std::size_t of_id = 0;
    for (const auto& e : r.contacts) of_id += e.object_id == id ? 1U : 0U;
    EXPECT_GE(of_id, 4U);
    EXPECT_EQ(of_id, r.contacts.size());  // no config wall, no other object
    c.bye();
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

TEST(ContactEvents, AConfigWallTheHandleIsPushedIntoBeginsAndEnds) {
    const Names n = names("contacts_wall");
    Child daemon(HAPTICD_BINARY, contact_daemon_args(n, {"--wall", "axis=0 position=0.002 direction=+1"}),
                 "contacts_wall_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    cl::Client c = cl::Client::connect({.socket_path = n.socket, .client_name = "contacts", .timeout_s = 30.0});
    const std::vector<std::uint32_t> initial = c.subscribe_contacts();
    EXPECT_TRUE(initial.empty());
    c.subscribe(1000.0);
    Received r;
    const cl::Field push{.center = {0, 0, 0}, .radius = 0.05, .force = {1.0, 0, 0}};
    const std::uint32_t field = c.commit(cl::Batch().add(push)).object_ids.at(0);
    EXPECT_GT(field, 1U);  // client ids follow the config walls'
    using K = cl::ContactEvent::Kind;
    ASSERT_TRUE(wait_sample(c, r, [&](const cl::StateSample& s) {
        return state_in_contact(s, 1) && state_in_contact(s, field);
    })) << "the handle never on wall 1";
    c.commit(cl::Batch().remove(field));
    ASSERT_TRUE(wait_sample(c, r, [&](const cl::StateSample& s) { return !state_in_contact(s, 1) && s.objects == 0; }))
        << "the handle does not leave wall 1";
    ASSERT_TRUE(wait_for_the_next_sample(c, r));
    EXPECT_GE(count_events(r, 1, K::Begin), 1U);
    EXPECT_GE(count_events(r, 1, K::End), 1U);
    EXPECT_EQ(count_events(r, field, K::Begin), 1U);  // inside its radius from the commit to the removal
    EXPECT_EQ(count_events(r, field, K::End), 1U);
    EXPECT_EQ(count_events(r, 1, K::Begin) + count_events(r, 1, K::End) + 2U, r.contacts.size());
    const auto seen = check_against_states(r, initial);
    EXPECT_GT(seen.count(1) != 0 ? seen.at(1) : 0U, 0U);
    // The wall's begin: the handle beyond x = 2 mm and the wall pushing back (-x).
    for (const auto& e : r.contacts) {
        if (e.object_id == 1 && e.kind == K::Begin) {
            EXPECT_GT(e.position[0], 0.002);
        }
    }
    c.bye();
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

// The daemon stops (SIGTERM) with a config wall and a client's field in contact: the subscriber receives an
// `end` of each before the session closes — the field's at the loop's last tick (force zero: the stop window's
// last tick); per object begin and end alternate and the last event is an end.
TEST(ContactEvents, EveryContactInProgressEndsWhenTheDaemonStops) {
    const Names n = names("contacts_stop");
    Child daemon(HAPTICD_BINARY, contact_daemon_args(n, {"--wall", "axis=0 position=0.002 direction=+1"}),
                 "contacts_stop_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    cl::Client c = cl::Client::connect({.socket_path = n.socket, .client_name = "contacts", .timeout_s = 30.0});
    EXPECT_TRUE(c.subscribe_contacts().empty());
    c.subscribe(1000.0);
    Received r;
    const cl::Field push{.center = {0, 0, 0}, .radius = 0.05, .force = {1.0, 0, 0}};
    const std::uint32_t field = c.commit(cl::Batch().add(push)).object_ids.at(0);
    ASSERT_TRUE(wait_sample(c, r, [&](const cl::StateSample& s) {
        return state_in_contact(s, 1) && state_in_contact(s, field);
    })) << "the handle never on wall 1";
    c.unsubscribe();
    daemon.signal(SIGTERM);
    // Every event until the server closes the session (30 s at most).
    const double end = monotonic_s() + 30.0;
    bool closed = false;
    while (!closed && monotonic_s() < end) {
        try {
            while (auto e = c.next_contact(0.1)) r.contacts.push_back(*e);
            closed = !daemon.running() && !c.poll_contact().has_value();
        } catch (const std::exception&) {
            closed = true;  // the session closed: what it had sent was read first
        }
    }
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
    ASSERT_GE(r.contacts.size(), 2U);
    std::map<std::uint32_t, const cl::ContactEvent*> last;
    std::map<std::uint32_t, bool> in;
    for (const auto& e : r.contacts) {
        EXPECT_EQ(e.dropped, 0U);
        EXPECT_NE(in[e.object_id], e.kind == cl::ContactEvent::Kind::Begin)
            << "object " << e.object_id << " tick " << e.tick << ": begin and end must alternate";
        in[e.object_id] = e.kind == cl::ContactEvent::Kind::Begin;
        last[e.object_id] = &e;
    }
    for (const std::uint32_t id : {1U, field}) {
        ASSERT_EQ(last.count(id), 1U) << "no event of object " << id;
        EXPECT_EQ(last[id]->kind, cl::ContactEvent::Kind::End) << "object " << id << " still in contact at the stop";
    }
    // The field (5 cm around the handle) is in contact to the end: its end is the loop's last tick, force zero.
    // The wall may end earlier: once the stop window has taken the force away, the hand pulls the handle out.
    EXPECT_EQ(last[field], &r.contacts.back());
    for (std::size_t a = 0; a < 3; ++a) EXPECT_EQ(last[field]->force[a], 0.0);
    EXPECT_LE(last[1]->tick, last[field]->tick);
    EXPECT_GT(r.contacts.back().tick, r.states.back().tick);
}

// A field without force (F0 = 0, J = 0) around the handle is in contact from the tick its commit is applied
// to the tick its ramp-out frees the slot, whatever the handle does: 20 adds and removals give exactly 20
// begins and 20 ends, alternating, each naming the id of that add, nothing dropped. The session subscribes to
// contact events only and waits in next_contact: the delay from an event's tick (its time_s, CLOCK_MONOTONIC)
// to its arrival here is printed (a figure of this machine and its load; docs/protocol.md, "Latency").
TEST(ContactEvents, TwentyFieldsAddedAndRemovedGiveTwentyBeginEndPairsInOrder) {
    const Names n = names("contacts_many");
    Child daemon(HAPTICD_BINARY, contact_daemon_args(n, {"--no-walls"}), "contacts_many_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    cl::Client c = cl::Client::connect({.socket_path = n.socket, .client_name = "contacts", .timeout_s = 30.0});
    EXPECT_TRUE(c.subscribe_contacts().empty());
    const cl::Field zero{.center = {0, 0, 0}, .radius = 0.05};
    std::vector<double> delays;
    std::uint64_t last_tick = 0;
    for (int i = 0; i < 20; ++i) {
        const std::uint32_t id = c.commit(cl::Batch().add(zero)).object_ids.at(0);
        c.commit(cl::Batch().remove(id));
        for (const auto kind : {cl::ContactEvent::Kind::Begin, cl::ContactEvent::Kind::End}) {
            const auto e = c.next_contact(30.0);
            ASSERT_TRUE(e.has_value()) << "add " << i << ": no event within 30 s";
            const double arrived = monotonic_s();
            EXPECT_EQ(e->object_id, id);
            EXPECT_EQ(e->kind, kind);
            EXPECT_EQ(e->dropped, 0U);
            if (!delays.empty()) {
                EXPECT_GT(e->tick, last_tick);  // the first may be the loop's tick 0
            }
            last_tick = e->tick;
            delays.push_back(arrived - e->time_s);
        }
    }
    EXPECT_FALSE(c.poll_contact().has_value());
    std::sort(delays.begin(), delays.end());
    std::printf("[ contacts ] tick to arrival: median %.3f ms, max %.3f ms over %zu events\n",
                1e3 * delays[delays.size() / 2], 1e3 * delays.back(), delays.size());
    c.bye();
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

// A contact subscriber that does not read loses its own events, counted, and stalls nobody: a field around
// the handle (radius 1 mm, no force) moved out of and back into contact 1600 times by a session that reads,
// each move applied before the next (it glides over the time since the last: the transitions are whatever the
// loop rendered, not necessarily one per move); a second
// session subscribed and not reading (its socket and its 256-message queue at the server fill after ~450
// messages). The reader gets every event, begin and end alternating, nothing dropped, every commit
// answered. Then the non-reader reads; fields are added and removed until it has received one of them. It
// has received a subsequence of the reader's events in order, and its last message's `dropped` is exactly
// the number of the reader's events up to that one it did not receive, and > 0.
TEST(ContactEvents, ANonReadingSubscriberLosesItsOwnEventsCountedAndStallsNobody) {
    const Names n = names("contacts_slow");
    // The loop at SCHED_FIFO as deployed: at normal priority, under ASan beside a parallel test, the storm of
    // 1600 commits stalled it for more than the watchdog's 100 periods and the daemon stopped with a fault.
    Child daemon(HAPTICD_BINARY, contact_daemon_args(n, {"--no-walls"}, "80"), "contacts_slow_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    cl::Client reader = cl::Client::connect({.socket_path = n.socket, .client_name = "reader", .timeout_s = 30.0});
    cl::Client sleeper = cl::Client::connect({.socket_path = n.socket, .client_name = "sleeper", .timeout_s = 30.0});
    EXPECT_TRUE(reader.subscribe_contacts().empty());
    EXPECT_TRUE(sleeper.subscribe_contacts().empty());
    using K = cl::ContactEvent::Kind;
    const cl::Field in{.center = {0, 0, 0}, .radius = 0.001};
    const cl::Field out{.center = {0.01, 0, 0}, .radius = 0.001};
    std::vector<cl::ContactEvent> got;
    // Reads the reader's events until one of `id` of `kind` (60 s at most).
    auto take_until = [&](std::uint32_t id, K kind) {
        const double end = monotonic_s() + 60.0;
        while (monotonic_s() < end) {
            if (auto e = reader.next_contact(0.1)) {
                got.push_back(*e);
                if (e->object_id == id && e->kind == kind) return true;
            }
        }
        return false;
    };
    const std::uint32_t storm = reader.commit(cl::Batch().add(in)).object_ids.at(0);
    constexpr int kMoves = 1600;
    const cl::StateReader state = cl::StateReader::open(reader.welcome().state_shm);
    for (int i = 0; i < kMoves; ++i) {
        const std::uint64_t seq = reader.commit(cl::Batch().modify(storm, i % 2 == 0 ? out : in)).commit_seq;
        // Applied before the next (the session's in-flight limit): every move is rendered for at least a tick.
        ASSERT_TRUE(wait_state(
            state, [&](const cl::StateSample& s) { return s.last_commit_seq >= seq; }, 30.0))
            << "move " << i;
    }
    reader.commit(cl::Batch().remove(storm));
    ASSERT_TRUE(take_until(storm, K::End));
    std::vector<cl::ContactEvent> slept;
    for (int j = 0; j < 20 && (slept.empty() || slept.back().object_id == storm); ++j) {
        while (auto e = sleeper.next_contact(0.5)) slept.push_back(*e);
        const std::uint32_t y = reader.commit(cl::Batch().add(in)).object_ids.at(0);
        ASSERT_TRUE(take_until(y, K::Begin));
        reader.commit(cl::Batch().remove(y));
        ASSERT_TRUE(take_until(y, K::End));
        while (auto e = sleeper.next_contact(1.0)) slept.push_back(*e);
    }
    ASSERT_FALSE(slept.empty());
    ASSERT_NE(slept.back().object_id, storm) << "the non-reader never received a later field's event";
    std::map<std::uint32_t, bool> in_contact;
    for (const auto& e : got) {
        EXPECT_NE(in_contact[e.object_id], e.kind == K::Begin) << "object " << e.object_id << " tick " << e.tick;
        in_contact[e.object_id] = e.kind == K::Begin;
        EXPECT_EQ(e.dropped, 0U);
    }
    std::size_t k = 0;  // the non-reader's events are a subsequence of the reader's, in order
    for (const auto& e : slept) {
        while (k < got.size() && !(got[k].tick == e.tick && got[k].object_id == e.object_id && got[k].kind == e.kind))
            ++k;
        ASSERT_LT(k, got.size()) << "an event the reader did not get, tick " << e.tick;
        ++k;
    }
    EXPECT_EQ(slept.back().dropped, k - slept.size());
    EXPECT_GT(slept.back().dropped, 0U);
    std::printf("[ contacts ] reader %zu events, non-reader %zu received, %llu dropped\n", got.size(), slept.size(),
                static_cast<unsigned long long>(slept.back().dropped));
    reader.bye();
    sleeper.bye();
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

constexpr char kContactsTag[] = "contacts_proto";
class ContactSubscription : public SharedDaemonTest<kContactsTag> {};

TEST_F(ContactSubscription, AMalformedSubscribeContactsGetsAnErrorNamingTheFieldAndTheSessionGoesOn) {
    RawConnection c(n_->socket);
    c.hello();
    for (const char* bad : {R"({"type":"subscribe_contacts","id":2,"object_ids":"all"})",
                            R"({"type":"subscribe_contacts","id":2,"object_ids":[]})",
                            R"({"type":"subscribe_contacts","id":2,"object_ids":[3,0]})",
                            R"({"type":"subscribe_contacts","id":2,"object_ids":[4294967296]})",
                            R"({"type":"subscribe_contacts","id":2,"object_ids":[-1]})"}) {
        c.send(bad);
        const json r = c.receive_json();
        EXPECT_EQ(r.value("type", ""), "error") << bad << " -> " << r.dump();
        EXPECT_EQ(r.value("code", ""), "bad_message") << r.dump();
        EXPECT_EQ(r.value("id", 0), 2) << r.dump();
        EXPECT_NE(r.value("message", "").find("subscribe_contacts.object_ids"), std::string::npos) << r.dump();
        EXPECT_NE(r.value("message", "").find("1 .. 64"), std::string::npos) << r.dump();
    }
    c.send(R"({"type":"subscribe_contacts","object_ids":[1]})");  // no id
    EXPECT_EQ(c.receive_json().value("code", ""), "bad_message");
    // A well-formed one is accepted on the same connection: the objects in contact (none here: the
    // suite's wall at x = 0.05 m is never touched), and unsubscribing.
    c.send(R"({"type":"subscribe_contacts","id":3,"object_ids":[1,2]})");
    json r = c.receive_json();
    EXPECT_EQ(r.value("type", ""), "ok") << r.dump();
    EXPECT_EQ(r.value("id", 0), 3);
    EXPECT_EQ(r["contacts"], json::array()) << r.dump();
    c.send(R"({"type":"unsubscribe_contacts","id":4})");
    r = c.receive_json();
    EXPECT_EQ(r.value("type", ""), "ok") << r.dump();
    EXPECT_EQ(r.value("id", 0), 4);
}

}  // namespace
}  // namespace hapticd::server_test
