// SPDX-License-Identifier: Apache-2.0
// A real client process for the server tests, on the installed-style client library (hapticd::client).
//   hapticd_test_client SOCKET commit '<ops JSON array>' [--lease S] [--then exit|hold|hold-silent|bye]
//       commits one batch, prints one JSON line {"ok":..., "code":..., "object_ids":[...], "largest_stable_K":...},
//       then exits, holds (heartbeat every lease/4), holds without heartbeats, or says bye.
//   hapticd_test_client SOCKET flood N OBJECT_ID_PLANE_OFFSETS
//       adds a plane, then N modify commits moving it as fast as it can; prints {"ok":n_ok,"busy":n_busy,...}.
//   hapticd_test_client SOCKET gainflood
//       adds a bilateral plane through the hand's start (n = -z at z = 0: a hand that never moves along z feels
//       exactly zero force from it), then changes its gains back and forth (each change
//       a cross-fade ramp in the loop) as fast as the server accepts; busy and session_limit are retried after
//       5 ms. Prints one line per request as it is answered, [t_sent, t_replied, commit_seq] (CLOCK_MONOTONIC
//       seconds; commit_seq 0 for a refusal), until SIGUSR1 (or 120 s); then {"ok":n_ok,"refused":n_refused}.
//   hapticd_test_client SOCKET noread
//       subscribes at 1000 Hz and never reads again (sleeps until killed).
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "client/object_json.hpp"
#include "hapticd/client.hpp"

namespace cl = hapticd::client;
using nlohmann::json;

namespace {

volatile std::sig_atomic_t g_stop_flooding = 0;  // set by SIGUSR1 (gainflood)

// Each reply is waited for this long: under the sanitizers a commit's checks run tens of times slower than in
// release while dozens of clients queue for the one server thread (a 5 s default was exceeded by 32 clients
// under ASan). The tests bound what they measure themselves (force-zero times, counts), not this.
constexpr double kReplyTimeout = 30.0;  // s

cl::Batch batch_from_json(const json& ops) {
    cl::Batch b;
    for (const auto& op : ops) {
        const std::string kind = op.at("op").get<std::string>();
        std::string why;
        if (kind == "add" || kind == "modify") {
            const auto object = cl::object_from_json(op.at("object"), why);
            if (!object) throw std::runtime_error("batch_from_json: " + why);
            if (kind == "add") {
                b.add(*object);
            } else {
                b.modify(op.at("object_id").get<std::uint32_t>(), *object);
            }
        } else if (kind == "remove") {
            b.remove(op.at("object_id").get<std::uint32_t>());
        } else {
            b.clear();
        }
    }
    return b;
}

void print(const json& j) { std::cout << j.dump() << std::endl; }

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::cerr << "usage: hapticd_test_client SOCKET commit|flood|noread ...\n";
        return 2;
    }
    const std::string socket = argv[1];
    const std::string mode = argv[2];
    try {
        if (mode == "commit") {
            if (argc < 4) return 2;
            double lease = 0.0;
            std::string then = "exit";
            for (int i = 4; i + 1 < argc; i += 2) {
                const std::string a = argv[i];
                if (a == "--lease") lease = std::atof(argv[i + 1]);
                if (a == "--then") then = argv[i + 1];
            }
            cl::Client c = cl::Client::connect(
                {.socket_path = socket, .client_name = "test-client", .lease_s = lease, .timeout_s = kReplyTimeout});
            json out;
            try {
                // busy (the hand-over queue is full) is retryable by the protocol: up to 1000 tries, 1 ms apart.
                const cl::Batch batch = batch_from_json(json::parse(argv[3]));
                cl::CommitResult r;
                for (int attempt = 0;; ++attempt) {
                    try {
                        r = c.commit(batch);
                        break;
                    } catch (const cl::Error& e) {
                        if (e.code() != cl::ErrorCode::Busy || attempt >= 1000) throw;
                        std::this_thread::sleep_for(std::chrono::milliseconds(1));
                    }
                }
                out = {{"ok", true},
                       {"object_ids", r.object_ids},
                       {"commit_seq", r.commit_seq},
                       {"session", c.welcome().session}};
            } catch (const cl::Error& e) {
                out = {{"ok", false},
                       {"code", cl::to_string(e.code())},
                       {"message", e.what()},
                       {"op_index", e.op_index()}};
                if (e.largest_stable_K()) out["largest_stable_K"] = *e.largest_stable_K();
            }
            print(out);
            if (then == "hold") {
                const double period = lease > 0.0 ? lease / 4.0 : 0.05;
                for (;;) {
                    std::this_thread::sleep_for(std::chrono::duration<double>(period));
                    c.heartbeat();
                }
            }
            if (then == "hold-silent") {
                for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
            }
            if (then == "bye") c.bye();
            return 0;
        }
        if (mode == "flood") {
            const long n = argc > 3 ? std::atol(argv[3]) : 1000;
            cl::Client c =
                cl::Client::connect({.socket_path = socket, .client_name = "flooder", .timeout_s = kReplyTimeout});
            cl::Plane p{.normal = {0.0, 0.0, -1.0},
                        .offset = -0.05,
                        .bilateral = false,
                        .gains = cl::Gains::explicit_gains(100.0, 1.0)};
            const auto id = c.commit(cl::Batch().add(p)).object_ids.at(0);
            long ok = 0, busy = 0;
            for (long i = 0; i < n; ++i) {
                p.offset = -0.05 - 1e-6 * static_cast<double>(i % 100);
                try {
                    c.commit(cl::Batch().modify(id, p));
                    ++ok;
                } catch (const cl::Error& e) {
                    if (e.code() != cl::ErrorCode::Busy && e.code() != cl::ErrorCode::SessionLimit)
                        throw;  // both: retry
                    ++busy;
                }
            }
            print({{"ok", ok}, {"busy", busy}});
            return 0;
        }
        if (mode == "gainflood") {
            struct sigaction stop {};
            stop.sa_handler = [](int) { g_stop_flooding = 1; };
            sigemptyset(&stop.sa_mask);
            sigaction(SIGUSR1, &stop, nullptr);
            cl::Client c =
                cl::Client::connect({.socket_path = socket, .client_name = "gainflooder", .timeout_s = kReplyTimeout});
            // Bilateral: one engagement pattern per ramp scene, so each change's check is short.
            cl::Plane p{.normal = {0.0, 0.0, -1.0},
                        .offset = 0.0,
                        .bilateral = true,
                        .gains = cl::Gains::explicit_gains(100.0, 1.0)};
            const auto id = c.commit(cl::Batch().add(p)).object_ids.at(0);
            long ok = 0, refused = 0;
            const auto seconds_now = [] {
                return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
            };
            const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(120);
            for (long i = 0; g_stop_flooding == 0 && std::chrono::steady_clock::now() < give_up; ++i) {
                p.gains = i % 2 == 0 ? cl::Gains::explicit_gains(150.0, 1.5) : cl::Gains::explicit_gains(100.0, 1.0);
                const double sent = seconds_now();
                try {
                    const auto seq = c.commit(cl::Batch().modify(id, p)).commit_seq;
                    ++ok;
                    print(json::array({sent, seconds_now(), seq}));
                } catch (const cl::Error& e) {
                    if (e.code() != cl::ErrorCode::Busy && e.code() != cl::ErrorCode::SessionLimit) throw;
                    print(json::array({sent, seconds_now(), 0}));
                    ++refused;
                    --i;  // the same change again
                    std::this_thread::sleep_for(std::chrono::milliseconds(5));
                }
            }
            print({{"ok", ok}, {"refused", refused}});
            return 0;
        }
        if (mode == "noread") {
            cl::Client c =
                cl::Client::connect({.socket_path = socket, .client_name = "noread", .timeout_s = kReplyTimeout});
            c.commit(cl::Batch().add(cl::Plane{.normal = {0.0, 0.0, -1.0},
                                               .offset = -0.05,
                                               .bilateral = false,
                                               .gains = cl::Gains::explicit_gains(100.0, 1.0)}));
            c.subscribe(1000.0);
            print({{"ok", true}});
            for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
        }
    } catch (const std::exception& e) {
        print({{"ok", false}, {"code", "exception"}, {"message", e.what()}});
        return 1;
    }
    return 2;
}
