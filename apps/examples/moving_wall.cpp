// SPDX-License-Identifier: Apache-2.0
// A wall that moves sinusoidally (docs/clients.md): one plane whose offset follows
//   offset(t) = offset + amplitude sin(2 pi frequency t)
// sent at --update-rate. Changing only where a plane is applies at the next tick without a ramp
// (docs/protocol.md, section 4), so the surface moves smoothly with the updates; the daemon's force-rate
// limit bounds what a large jump could do. The gains are the daemon's optimum for --criterion (or explicit
// --stiffness/--damping). At the end it prints how many updates the loop applied and the force it rendered.
//   moving_wall [--socket PATH] [--normal -1,0,0] [--offset 0.005] [--amplitude 0.002] [--frequency 1]
//               [--update-rate 200] [--duration 3] [--criterion CE2 | --stiffness K --damping B]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include "example_options.hpp"

namespace hc = hapticd::client;

int main(int argc, char** argv) {
    const examples::Options o(argc, argv,
                              {{"socket", ""},
                               {"normal", "-1,0,0"},
                               {"offset", "0.005"},
                               {"amplitude", "0.002"},
                               {"frequency", "1"},
                               {"update-rate", "200"},
                               {"duration", "3"},
                               {"criterion", "CE2"},
                               {"stiffness", "0"},
                               {"damping", "0"}});
    const hc::Vec3 n = o.vec3("normal");
    const double offset = o.number("offset");
    const double amplitude = o.number("amplitude");
    const double frequency = o.number("frequency");
    const double rate = o.number("update-rate");
    const double duration = o.number("duration");
    if (rate <= 0.0 || rate > 1000.0 || duration <= 0.0) {
        std::fprintf(stderr, "moving_wall: --update-rate must be in (0, 1000] Hz and --duration > 0 s\n");
        return 2;
    }
    const hc::Gains gains = o.number("stiffness") > 0.0
                                ? hc::Gains::explicit_gains(o.number("stiffness"), o.number("damping"))
                                : hc::Gains::by_criterion(o.text("criterion"));
    examples::install_stop_handlers();
    bool connected = false;
    try {
        hc::ConnectOptions co;
        co.socket_path = o.text("socket");
        co.client_name = "moving_wall";
        co.lease_s = 0.5;  // every update renews it; a frozen example loses its wall within 0.5 s
        hc::Client client = hc::Client::connect(co);
        connected = true;
        const hc::StateReader state = hc::StateReader::open(client.welcome().state_shm);
        hc::Plane wall{n, offset, false, gains};
        const std::uint32_t id = client.commit(hc::Batch().add(wall)).object_ids.front();
        for (const auto& info : client.list()) {
            if (info.id == id) std::printf("moving_wall: plane %u, K = %g N/m, B = %g N s/m\n", id, info.K, info.B);
        }
        std::fflush(stdout);
        const auto start = std::chrono::steady_clock::now();
        const auto step = std::chrono::duration<double>(1.0 / rate);
        std::uint64_t updates = 0, last_seq = 0, samples = 0, in_contact = 0;
        double force_min = 0.0, force_max = 0.0;
        for (auto next = start; !examples::g_stop;
             next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(step)) {
            std::this_thread::sleep_until(next);
            const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            if (t >= duration) break;
            wall.offset = offset + amplitude * std::sin(2.0 * M_PI * frequency * t);
            last_seq = client.commit(hc::Batch().modify(id, wall)).commit_seq;
            ++updates;
            hc::StateSample s;
            if (state.read(s)) {
                const double along =
                    s.force[0] * n[0] + s.force[1] * n[1] + s.force[2] * n[2];  // the wall pushes along n
                force_min = samples == 0 ? along : std::min(force_min, along);
                force_max = samples == 0 ? along : std::max(force_max, along);
                ++samples;
                for (std::size_t slot = 0; slot < s.slot_object_id.size(); ++slot) {
                    if (s.slot_object_id[slot] == id && (s.contact_mask >> slot & 1U) != 0U) ++in_contact;
                }
            }
        }
        // Wait (briefly) until the loop has applied the last update.
        hc::StateSample s;
        bool applied = false;
        for (int i = 0; i < 1000 && !applied; ++i) {
            applied = state.read(s) && s.last_commit_seq >= last_seq;
            if (!applied) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        std::printf(
            "moving_wall: %llu updates sent, last applied %s; in contact in %llu of %llu samples; "
            "force along the normal %.3f .. %.3f N\n",
            static_cast<unsigned long long>(updates), applied ? "yes" : "no",
            static_cast<unsigned long long>(in_contact), static_cast<unsigned long long>(samples), force_min,
            force_max);
        client.bye();  // the wall ramps out
        return applied ? 0 : 8;
    } catch (const hc::Error& e) {
        std::fprintf(stderr, "moving_wall: %s\n", e.what());
        return examples::exit_code(e, connected);
    }
}
