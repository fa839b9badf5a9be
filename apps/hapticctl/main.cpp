// SPDX-License-Identifier: Apache-2.0
// hapticctl: the command-line client of `hapticd --serve` (docs/clients.md), on the C++ client library.
//   hapticctl status | list [--json]
//   hapticctl add plane normal=0,0,1 offset=0.01 criterion=CE2 [--for SECONDS]
//   hapticctl session [FILE]          (commands from FILE or stdin, one session)
//   hapticctl watch [--rate HZ] [--count N] [--duration S] [--via-socket]   (a stream socket: by subscription)
//   hapticctl contacts [--count N] [--duration S] [--object ID ...]
// An object lives as long as the session that added it (docs/protocol.md, section 7): `add` holds its
// session until SIGINT/SIGTERM or --for; `session` runs add/modify/remove/clear in one session.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hapticd/instance.hpp"

#include "exit_codes.hpp"
#include "mesh_file.hpp"
#include "object_spec.hpp"
#include "session_script.hpp"
#include "state_line.hpp"

namespace hc = hapticd::client;
using namespace hapticctl;

namespace {

struct Common {
    std::string socket;
    std::string instance;  // hapticd --instance NAME: its socket (include/hapticd/instance.hpp)
    double timeout = 5.0;
    double lease = 1.0;
    std::string name = "hapticctl";
};

hc::Client connect(const Common& c, double lease) {
    hc::ConnectOptions o;
    o.socket_path = c.socket;
    o.instance = c.instance;
    o.client_name = c.name;
    o.lease_s = lease;
    o.timeout_s = c.timeout;
    return hc::Client::connect(o);
}

// The device's mass matrix on its axes (row by row), as the welcome gives it.
nlohmann::json mass_matrix_json(const hc::DeviceInfo& d) {
    nlohmann::json rows = nlohmann::json::array();
    for (std::size_t i = 0; i < d.axes && i < 3; ++i) {
        nlohmann::json row = nlohmann::json::array();
        for (std::size_t j = 0; j < d.axes && j < 3; ++j) row.push_back(d.mass_matrix[i][j]);
        rows.push_back(row);
    }
    return rows;
}

// "mass 0.3 kg" for one mass on every axis (M = m I), else the per-axis masses and the matrix.
std::string mass_text(const hc::DeviceInfo& d) {
    bool isotropic = true;
    for (std::size_t i = 0; i < d.axes && i < 3; ++i) {
        for (std::size_t j = 0; j < d.axes && j < 3; ++j) {
            if (d.mass_matrix[i][j] != (i == j ? d.mass_matrix[0][0] : 0.0)) isotropic = false;
        }
    }
    std::ostringstream out;
    if (isotropic) {
        out << "mass " << d.mass_matrix[0][0] << " kg";
        return out.str();
    }
    out << "mass per axis [";
    for (std::size_t a = 0; a < d.axes && a < 3; ++a) out << (a > 0 ? " " : "") << d.mass[a];
    out << "] kg (1/(M^-1)_aa), mass matrix " << mass_matrix_json(d).dump() << " kg";
    return out.str();
}

int cmd_status(const Common& common, bool json) {
    hc::Client client = connect(common, 0.0);
    const hc::Status s = client.status();
    const hc::Welcome& w = client.welcome();
    const nlohmann::json max_stiffness =
        w.device.max_stiffness ? nlohmann::json(*w.device.max_stiffness) : nlohmann::json();
    if (json) {
        std::cout << nlohmann::json{{"tick", s.tick},
                                    {"sessions", s.sessions},
                                    {"objects", s.objects},
                                    {"overruns", s.overruns},
                                    {"commits_applied", s.commits_applied},
                                    {"commit_check", s.commit_check_session
                                                         ? nlohmann::json{{"session", *s.commit_check_session},
                                                                          {"running_s", s.commit_check_running_s}}
                                                         : nlohmann::json()},
                                    {"commits_waiting", s.commits_waiting},
                                    {"departures_waiting", s.departures_waiting},
                                    {"fault", s.fault},
                                    {"protocol", w.protocol},
                                    {"device",
                                     {{"name", w.device.name},
                                      {"axes", w.device.axes},
                                      {"period_s", w.device.period_s},
                                      {"mass", w.device.mass},
                                      {"mass_matrix", mass_matrix_json(w.device)},
                                      {"delay_s", w.device.delay_s},
                                      {"max_force", w.device.max_force},
                                      {"max_stiffness", max_stiffness},
                                      {"velocity_estimator", w.device.velocity_estimator}}},
                                    {"capacity", w.capacity},
                                    {"state_shm", w.state_shm},
                                    {"ramp_s", w.ramp_s}}
                         .dump()
                  << "\n";
    } else {
        std::cout << "device " << w.device.name << ": " << w.device.axes << " axes, period " << w.device.period_s * 1e3
                  << " ms, delay " << w.device.delay_s * 1e3 << " ms, max force " << w.device.max_force << " N, "
                  << mass_text(w.device) << ", max stiffness ";
        if (w.device.max_stiffness) {
            std::cout << *w.device.max_stiffness << " N/m";
        } else {
            std::cout << "none (the stability region only)";
        }
        std::cout << ", velocity estimate " << w.device.velocity_estimator << "\n"
                  << "tick " << s.tick << ", sessions " << s.sessions << ", objects " << s.objects << " of "
                  << w.capacity << ", overruns " << s.overruns << ", commits applied " << s.commits_applied
                  << ", fault " << s.fault << "\nstate stream " << w.state_shm << ", ramp " << w.ramp_s * 1e3
                  << " ms, protocol " << w.protocol << "\n";
        if (s.commit_check_session) {
            std::cout << "checking the scenes of session " << *s.commit_check_session << "'s commit for "
                      << s.commit_check_running_s << " s; " << s.commits_waiting << " commits of other sessions wait\n";
        }
        if (s.departures_waiting > 0) {
            std::cout << s.departures_waiting
                      << " sessions gone whose objects render until their departure is planned\n";
        }
    }
    client.bye();
    return kExitOk;
}

int cmd_list(const Common& common, bool json) {
    hc::Client client = connect(common, 0.0);
    print_objects(std::cout, client.list(), json);
    client.bye();
    return kExitOk;
}

int cmd_add(const Common& common, const std::vector<std::string>& given, double hold_s) {
    // `add mesh FILE [mode=solid|surface] [scale=S] key=value...`: the file read here (assimp), uploaded, then
    // added as `mesh mesh=ID key=value...`.
    std::vector<std::string> words = given;
    std::optional<MeshFile> file;
    bool solid = true;
    if (words.size() >= 2 && words[0] == "mesh" && words[1].find('=') == std::string::npos) {
        double scale = 1.0;
        std::vector<std::string> rest{"mesh", "mesh=1"};  // the id is set once uploaded
        for (std::size_t i = 2; i < words.size(); ++i) {
            if (words[i].rfind("mode=", 0) == 0) {
                const std::string mode = words[i].substr(5);
                if (mode != "solid" && mode != "surface") {
                    throw SpecError("add mesh: mode = '" + mode + "'; accepted: solid, surface");
                }
                solid = mode == "solid";
            } else if (words[i].rfind("scale=", 0) == 0) {
                char* end = nullptr;
                scale = std::strtod(words[i].c_str() + 6, &end);
                if (*end != '\0') throw SpecError("add mesh: scale = '" + words[i].substr(6) + "' is not a number");
            } else {
                rest.push_back(words[i]);
            }
        }
        (void)parse_object_spec(rest);  // the keys checked before the file is read
        file = load_mesh_file(words[1], scale);
        words = rest;
    }
    hc::ObjectDescription object = parse_object_spec(words);  // before connecting: a typo costs nothing
    hc::Client client = connect(common, common.lease);
    if (file) {
        std::get<hc::Mesh>(object).mesh = client.upload_mesh(file->vertices, file->triangles, solid);
        std::cout << "uploaded " << given[1] << ": " << file->vertices.size() << " vertices, " << file->triangles.size()
                  << " triangles (" << (solid ? "solid" : "surface") << ")" << std::endl;
    }
    hc::Batch batch;
    batch.add(object);
    const hc::CommitResult r = client.commit(batch);
    const std::uint32_t id = r.object_ids.front();
    for (const auto& o : client.list()) {
        if (o.id == id) {
            std::cout << "added " << id << " (" << o.kind << ", K = " << o.K << " N/m, B = " << o.B
                      << " N s/m); held until "
                      << (hold_s > 0 ? "--for " + std::to_string(hold_s) + " s or " : std::string())
                      << "SIGINT/SIGTERM, then it ramps out" << std::endl;
        }
    }
    sleep_with_heartbeats(client, hold_s > 0 ? hold_s : 1e9);
    client.bye();
    return kExitOk;
}

int cmd_session(const Common& common, const std::string& file) {
    std::ifstream in_file;
    std::istream* in = &std::cin;
    std::string source = "stdin";
    if (!file.empty() && file != "-") {
        in_file.open(file);
        if (!in_file) {
            std::cerr << "hapticctl: session: cannot open '" << file << "'\n";
            return kExitUsage;
        }
        in = &in_file;
        source = file;
    }
    hc::Client client = connect(common, common.lease);
    return run_session_script(client, *in, source, std::cout, std::cerr);
}

int cmd_watch(const Common& common, double rate, long long count, double duration, bool via_socket, double stall_s,
              std::string shm) {
    std::optional<hc::Client> client;
    std::size_t axes = 3;
    double period_s = 0.0;
    if (via_socket || shm.empty()) {
        client.emplace(connect(common, 0.0));
        axes = client->welcome().device.axes;
        period_s = client->welcome().device.period_s;
        if (shm.empty()) shm = client->welcome().state_shm;
    }
    // --shm: that segment, no session. Else the session's StateSource: the shared memory when it can be opened
    // here over the SOCK_SEQPACKET socket, a subscription over the stream transport (a forwarded socket: the
    // daemon may be on another machine) or with --via-socket.
    std::optional<hc::StateReader> reader;
    std::optional<hc::StateSource> source;
    if (!client) {
        reader.emplace(hc::StateReader::open(shm));
        axes = reader->axes();
        period_s = reader->period_s();
    } else {
        source.emplace(*client, rate, via_socket ? hc::StateSource::Mode::Subscribe : hc::StateSource::Mode::Auto);
        via_socket = !source->shared_memory();
    }
    const bool tty = ::isatty(STDOUT_FILENO) != 0;
    const auto start = std::chrono::steady_clock::now();
    const auto period = std::chrono::duration<double>(1.0 / rate);
    auto last_change = start;
    std::uint64_t last_tick = 0;
    bool have_tick = false;
    long long shown = 0;
    int code = kExitOk;
    while (!stop_requested()) {
        hc::StateSample s;
        if (via_socket) {
            const auto next = source->read(stall_s);
            if (!next) {
                std::cerr << "\nhapticctl: watch: no state message for " << stall_s << " s\n";
                code = kExitNoState;
                break;
            }
            s = *next;
        } else {
            std::this_thread::sleep_for(shown == 0 ? std::chrono::duration<double>(0) : period);
            std::optional<hc::StateSample> got;
            if (reader) {
                if (reader->read(s)) got = s;
            } else {
                got = source->read();
            }
            if (!got) continue;  // the writer kept overlapping: try at the next refresh
            s = *got;
        }
        const auto now = std::chrono::steady_clock::now();
        if (!have_tick || s.tick != last_tick) {
            last_tick = s.tick;
            last_change = now;
            have_tick = true;
        }
        const std::string text = state_line(s, axes, period_s);
        if (tty) {
            std::cout << "\r" << text << "\x1b[K" << std::flush;
        } else {
            std::cout << text << "\n" << std::flush;
        }
        ++shown;
        if (s.fault != 0) {
            std::cerr << (tty ? "\n" : "") << "hapticctl: watch: the daemon reports fault " << fault_name(s.fault)
                      << " (its force is zero, the loop stopped)\n";
            code = kExitNoState;
            break;
        }
        if (std::chrono::duration<double>(now - last_change).count() > stall_s) {
            std::cerr << (tty ? "\n" : "") << "hapticctl: watch: the loop has not advanced for " << stall_s
                      << " s (tick " << last_tick << "): is hapticd still running?\n";
            code = kExitNoState;
            break;
        }
        if (count > 0 && shown >= count) break;
        if (duration > 0 && std::chrono::duration<double>(now - start).count() >= duration) break;
    }
    if (tty) std::cout << "\n";
    if (client) client->bye();
    return code;
}

// Contact events (docs/protocol.md, section 6, "Contact events") as JSON lines: first {"contacts": [ids in
// contact where the events start]}, then one line per begin or end, in the protocol message's fields.
int cmd_contacts(const Common& common, long long count, double duration, const std::vector<std::uint32_t>& objects) {
    hc::Client client = connect(common, 0.0);
    const std::vector<std::uint32_t> in_contact = client.subscribe_contacts(objects);
    std::cout << nlohmann::json{{"contacts", in_contact}}.dump() << "\n" << std::flush;
    const auto start = std::chrono::steady_clock::now();
    long long shown = 0;
    while (!stop_requested() && (count <= 0 || shown < count)) {
        if (duration > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >= duration)
            break;
        const auto e = client.next_contact(0.1);  // short: SIGINT/SIGTERM and --duration are seen within 0.1 s
        if (!e) continue;
        nlohmann::json line{{"event", e->kind == hc::ContactEvent::Kind::Begin ? "begin" : "end"},
                            {"object_id", e->object_id},
                            {"tick", e->tick},
                            {"time_s", e->time_s},
                            {"position", e->position},
                            {"force", e->force},
                            {"dropped", e->dropped}};
        std::cout << line.dump() << "\n" << std::flush;
        ++shown;
    }
    client.bye();
    return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"hapticctl: the command-line client of hapticd --serve (docs/clients.md)"};
    app.footer(kExitCodeHelp);
    app.require_subcommand(1);
    Common common;
    auto* socket = app.add_option("--socket", common.socket,
                                  "Control socket (default: $HAPTICD_SOCKET, the socket of $HAPTICD_INSTANCE, "
                                  "$RUNTIME_DIRECTORY/hapticd.sock, $XDG_RUNTIME_DIR/hapticd.sock, "
                                  "/run/hapticd/hapticd.sock)");
    app.add_option("--instance", common.instance,
                   "The daemon instance (hapticd --instance NAME): its socket hapticd-NAME.sock in "
                   "$RUNTIME_DIRECTORY, $XDG_RUNTIME_DIR or /run/hapticd")
        ->excludes(socket)
        ->check(
            [](const std::string& name) {
                return hapticd::valid_instance_name(name)
                           ? std::string()
                           : "--instance '" + name + "' is invalid; accepted: " + hapticd::kInstanceNameForm;
            },
            "NAME");
    app.add_option("--timeout", common.timeout, "Seconds to wait for each reply")->check(CLI::Range(0.01, 600.0));
    app.add_option("--lease", common.lease, "Lease of add/session in seconds (0: none; heartbeats at a third of it)")
        ->check(CLI::Range(0.0, 60.0));
    app.add_option("--name", common.name, "Client name in the daemon's log");

    bool json = false;
    auto* status = app.add_subcommand("status", "The daemon's device, tick, sessions, objects, overruns and fault");
    status->add_flag("--json", json, "One JSON object");
    auto* list = app.add_subcommand("list", "Every object in the scene with its owner and the gains in use");
    list->add_flag("--json", json, "A JSON array");

    std::vector<std::string> words;
    double hold = 0.0;
    auto* add = app.add_subcommand("add",
                                   "Add one object and hold it until SIGINT/SIGTERM (or --for): "
                                   "plane normal=X,Y,Z [offset=M] [mode=bilateral] [criterion=C | K= B=]; "
                                   "mesh FILE.stl|FILE.obj [mode=solid|surface] [scale=S] [position=X,Y,Z] "
                                   "[orientation=W,X,Y,Z] [criterion=C | K= B=] [static_friction= dynamic_friction=] "
                                   "[shading=CREASE_DEG]; "
                                   "spring [constraint=point|line|plane] point=X,Y,Z [direction=X,Y,Z] K= [B=]; "
                                   "field center=X,Y,Z radius=M [force=X,Y,Z] [jacobian=9 numbers]");
    add->add_option("object", words, "KIND key=value ...")->required()->expected(1, -1);
    add->add_option("--for", hold, "Seconds to hold the object, then end the session (ramp-out)")
        ->check(CLI::Range(0.0, 1e9));

    std::string script;
    auto* session = app.add_subcommand("session",
                                       "Run commands from FILE (default stdin) in one session: add, modify, "
                                       "remove, clear, begin/commit, list, status, state, sleep, bye");
    session->add_option("file", script, "Script file, '-' for stdin");

    double rate = 20.0;
    long long count = 0;
    double duration = 0.0;
    bool via_socket = false;
    double stall = 2.0;
    std::string shm;
    auto* watch = app.add_subcommand("watch", "The state as a live line (one line per sample when not a terminal)");
    watch->add_option("--rate", rate, "Samples per second")->check(CLI::Range(0.1, 1000.0));
    watch->add_option("--count", count, "Stop after N samples")->check(CLI::Range(0LL, 1LL << 40));
    watch->add_option("--duration", duration, "Stop after S seconds")->check(CLI::Range(0.0, 1e9));
    watch->add_flag("--via-socket", via_socket, "Subscribe over the socket instead of reading the shared memory");
    watch->add_option("--stall-timeout", stall, "Fail (exit 9) when the tick has not advanced for S seconds")
        ->check(CLI::Range(0.01, 3600.0));
    watch->add_option("--shm", shm, "Read this shared-memory name directly, without connecting");

    long long contact_count = 0;
    double contact_duration = 0.0;
    std::vector<std::uint32_t> contact_objects;
    auto* contacts =
        app.add_subcommand("contacts", "Each begin and end of contact as a JSON line (first: the objects in contact)");
    contacts->add_option("--count", contact_count, "Stop after N events")->check(CLI::Range(0LL, 1LL << 40));
    contacts->add_option("--duration", contact_duration, "Stop after S seconds")->check(CLI::Range(0.0, 1e9));
    contacts
        ->add_option("--object", contact_objects, "Only this object's events (repeatable, at most 64; ids 1 .. 2^32-1)")
        ->check(CLI::Range(1U, 0xffffffffU));

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? kExitOk : kExitUsage;
    }
    install_stop_signal_handlers();
    try {
        if (*status) return cmd_status(common, json);
        if (*list) return cmd_list(common, json);
        if (*add) return cmd_add(common, words, hold);
        if (*session) return cmd_session(common, script);
        if (*watch) return cmd_watch(common, rate, count, duration, via_socket, stall, shm);
        if (*contacts) return cmd_contacts(common, contact_count, contact_duration, contact_objects);
    } catch (const SpecError& e) {
        std::cerr << "hapticctl: " << e.what() << "\n";
        return kExitUsage;
    } catch (const hc::Error& e) {
        std::cerr << "hapticctl: " << e.what() << "\n";
        const std::string what = e.what();
        if (what.rfind("StateReader::open", 0) == 0) return kExitNoState;
        // A transport failure while connecting: no daemon (3); after the welcome: the session was lost (8).
        return exit_code_for(e, /*connected=*/what.rfind("Client::connect", 0) != 0);
    } catch (const std::invalid_argument& e) {  // e.g. a bad $HAPTICD_INSTANCE (the message names it)
        std::cerr << "hapticctl: " << e.what() << "\n";
        return kExitUsage;
    } catch (const std::exception& e) {
        std::cerr << "hapticctl: internal error: " << e.what() << "\n";
        return kExitInternal;
    }
    return kExitInternal;
}
