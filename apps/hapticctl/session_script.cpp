// SPDX-License-Identifier: Apache-2.0
#include "session_script.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <signal.h>

#include <csignal>
#include <cstdio>
#include <iomanip>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "exit_codes.hpp"
#include "object_spec.hpp"
#include "state_line.hpp"

namespace hapticctl {

namespace hc = hapticd::client;

namespace {

volatile std::sig_atomic_t g_stop = 0;

std::uint32_t parse_id(const std::string& word) {
    std::size_t used = 0;
    unsigned long v = 0;
    try {
        v = std::stoul(word, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used != word.size() || word.empty() || v == 0 || v > 0xFFFFFFFFUL) {
        throw SpecError("run_session_script: object id '" + word + "' is not an integer 1 .. 4294967295");
    }
    return static_cast<std::uint32_t>(v);
}

std::vector<std::string> tail(const std::vector<std::string>& w, std::size_t from) {
    return {w.begin() + static_cast<std::ptrdiff_t>(std::min(from, w.size())), w.end()};
}

void on_stop_signal(int) { g_stop = 1; }

}  // namespace

void install_stop_signal_handlers() {
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
}

bool stop_requested() noexcept { return g_stop != 0; }

void print_objects(std::ostream& out, const std::vector<hc::ObjectInfo>& objects, bool json) {
    if (json) {
        nlohmann::json a = nlohmann::json::array();
        for (const auto& o : objects) {
            a.push_back({{"id", o.id},
                         {"owner", o.owner},
                         {"kind", o.kind},
                         {"K", o.K},
                         {"B", o.B},
                         {"object", nlohmann::json::parse(o.description_json, nullptr, false)}});
        }
        out << a.dump() << "\n";
        return;
    }
    out << std::left << std::setw(6) << "id" << std::setw(8) << "owner" << std::setw(8) << "kind" << std::setw(14)
        << "K [N/m]" << std::setw(14) << "B [N s/m]"
        << "object\n";
    for (const auto& o : objects) {
        out << std::left << std::setw(6) << o.id << std::setw(8)
            << (o.owner == 0 ? std::string("daemon") : std::to_string(o.owner)) << std::setw(8) << o.kind
            << std::setw(14) << o.K << std::setw(14) << o.B << o.description_json << "\n";
    }
}

bool sleep_with_heartbeats(hc::Client& client, double seconds) {
    const double lease = client.welcome().lease_s;
    const double step = lease > 0.0 ? lease / 3.0 : 0.05;
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (!stop_requested()) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= end) return true;
        const double left = std::chrono::duration<double>(end - now).count();
        std::this_thread::sleep_for(std::chrono::duration<double>(std::min(step, left)));
        if (lease > 0.0) client.heartbeat();
    }
    return false;
}

int run_session_script(hc::Client& client, std::istream& in, const std::string& source, std::ostream& out,
                       std::ostream& err) {
    std::optional<hc::Batch> batch;
    std::optional<hc::StateReader> state;
    std::string line;
    std::size_t number = 0;
    auto where = [&] { return "hapticctl: " + source + ":" + std::to_string(number) + ": "; };
    auto commit = [&](const hc::Batch& b, bool print_ids) {
        const hc::CommitResult r = client.commit(b);
        if (print_ids) {
            for (const auto id : r.object_ids) out << "added " << id << "\n";
            out << "committed " << r.commit_seq << "\n";
        }
        return r;
    };
    try {
        while (std::getline(in, line)) {
            ++number;
            const auto hash = line.find('#');
            if (hash != std::string::npos) line.erase(hash);
            const std::vector<std::string> w = split_words(line);
            if (w.empty()) continue;
            const std::string& cmd = w.front();
            if (cmd == "add" || cmd == "modify" || cmd == "remove" || cmd == "clear") {
                hc::Batch one;
                hc::Batch& target = batch ? *batch : one;
                if (cmd == "add") {
                    target.add(parse_object_spec(tail(w, 1)));
                } else if (cmd == "modify") {
                    if (w.size() < 3) throw SpecError("run_session_script: modify ID SPEC");
                    target.modify(parse_id(w[1]), parse_object_spec(tail(w, 2)));
                } else if (cmd == "remove") {
                    if (w.size() != 2) throw SpecError("run_session_script: remove ID");
                    target.remove(parse_id(w[1]));
                } else {
                    if (w.size() != 1) throw SpecError("run_session_script: clear takes no arguments");
                    target.clear();
                }
                if (!batch) {
                    const hc::CommitResult r = commit(one, false);
                    if (cmd == "add")
                        out << "added " << r.object_ids.front() << "\n";
                    else
                        out << cmd << " ok\n";
                }
            } else if (cmd == "begin") {
                if (batch) throw SpecError("run_session_script: begin inside a batch (missing commit)");
                batch.emplace();
            } else if (cmd == "commit") {
                if (!batch) throw SpecError("run_session_script: commit without begin");
                commit(*batch, true);
                batch.reset();
            } else if (cmd == "list") {
                print_objects(out, client.list(), w.size() > 1 && w[1] == "--json");
            } else if (cmd == "status") {
                const hc::Status s = client.status();
                out << "tick " << s.tick << " sessions " << s.sessions << " objects " << s.objects << " overruns "
                    << s.overruns << " commits_applied " << s.commits_applied << " fault " << s.fault << "\n";
            } else if (cmd == "state") {
                if (!state) state.emplace(hc::StateReader::open(client.welcome().state_shm));
                // A read fails only while the writer keeps overlapping it (lockstep, or the loop preempted
                // mid-write): retry for up to 1 s.
                hc::StateSample s;
                bool ok = state->read(s);
                for (int i = 0; !ok && i < 1000; ++i) {
                    std::this_thread::sleep_for(std::chrono::milliseconds(1));
                    ok = state->read(s);
                }
                if (!ok)
                    throw hc::Error(hc::ErrorCode::Transport,
                                    "run_session_script: state: no consistent read within 1 s");
                out << state_line(s, client.welcome().device.axes, client.welcome().device.period_s) << "\n";
            } else if (cmd == "sleep") {
                if (w.size() != 2) throw SpecError("run_session_script: sleep SECONDS");
                char* end = nullptr;
                const double s = std::strtod(w[1].c_str(), &end);
                if (end != w[1].c_str() + w[1].size() || !std::isfinite(s) || s < 0.0 || s > 86400.0) {
                    throw SpecError("run_session_script: sleep " + w[1] + ": accepted 0 .. 86400 seconds");
                }
                if (!sleep_with_heartbeats(client, s)) break;
            } else if (cmd == "bye") {
                break;
            } else {
                throw SpecError(
                    "run_session_script: unknown command '" + cmd +
                    "'; accepted: add, modify, remove, clear, begin, commit, list, status, state, sleep, bye");
            }
            out.flush();
        }
        if (batch) throw SpecError("run_session_script: input ended inside a batch (missing commit)");
    } catch (const SpecError& e) {
        err << where() << e.what() << "\n";
        return kExitUsage;
    } catch (const hc::Error& e) {
        err << where() << e.what() << "\n";
        return exit_code_for(e, true);
    }
    client.bye();
    return kExitOk;
}

}  // namespace hapticctl
