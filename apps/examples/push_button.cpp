// SPDX-License-Identifier: Apache-2.0
// A virtual push-button (docs/clients.md): a unilateral plane of stiffness K with a detent. Pressing it
// past --click-depth makes the surface give way by --drop (the force falls by K drop: the click you feel)
// and prints "pressed"; coming back above --release-depth restores it and prints "released" (hysteresis,
// so the button does not chatter). The position is read from the shared-memory state at ~1 kHz;
// penetration p = offset - n.x (docs/protocol.md, section 4).
//   push_button [--socket PATH] [--normal -1,0,0] [--offset 0.005] [--stiffness 1000] [--damping 5]
//               [--click-depth 0.0015] [--drop 0.001] [--release-depth 0.0005] [--duration 3] [--presses 0]
// --duration 0: until SIGINT/SIGTERM; --presses N: exit after the N-th press.
#include <chrono>
#include <cstdio>
#include <thread>

#include "example_options.hpp"

namespace hc = hapticd::client;

int main(int argc, char** argv) {
    const examples::Options o(argc, argv,
                              {{"socket", ""},
                               {"normal", "-1,0,0"},
                               {"offset", "0.005"},
                               {"stiffness", "1000"},
                               {"damping", "5"},
                               {"click-depth", "0.0015"},
                               {"drop", "0.001"},
                               {"release-depth", "0.0005"},
                               {"duration", "3"},
                               {"presses", "0"}});
    const hc::Vec3 n = o.vec3("normal");
    const double offset = o.number("offset");
    const double click = o.number("click-depth");
    const double drop = o.number("drop");
    const double release = o.number("release-depth");
    const double duration = o.number("duration");
    const double max_presses = o.number("presses");
    if (!(click > 0.0 && drop > 0.0 && release >= 0.0 && release < click)) {
        std::fprintf(stderr,
                     "push_button: need --click-depth > 0, --drop > 0 and 0 <= --release-depth < --click-depth (m)\n");
        return 2;
    }
    examples::install_stop_handlers();
    bool connected = false;
    try {
        hc::ConnectOptions co;
        co.socket_path = o.text("socket");
        co.client_name = "push_button";
        co.lease_s = 0.5;
        hc::Client client = hc::Client::connect(co);
        connected = true;
        const hc::StateReader state = hc::StateReader::open(client.welcome().state_shm);
        hc::Plane button{n, offset, false, hc::Gains::explicit_gains(o.number("stiffness"), o.number("damping"))};
        const std::uint32_t id = client.commit(hc::Batch().add(button)).object_ids.front();
        std::printf("push_button: button %u ready (K = %g N/m, click at %.2f mm, gives %.2f mm)\n", id,
                    o.number("stiffness"), click * 1e3, drop * 1e3);
        std::fflush(stdout);
        const auto start = std::chrono::steady_clock::now();
        auto last_heartbeat = start;
        bool pressed = false;
        long presses = 0;
        while (!examples::g_stop) {
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
            const auto now = std::chrono::steady_clock::now();
            if (duration > 0.0 && std::chrono::duration<double>(now - start).count() >= duration) break;
            hc::StateSample s;
            if (!state.read(s)) continue;
            const double depth = offset - (n[0] * s.position[0] + n[1] * s.position[1] + n[2] * s.position[2]);
            if (!pressed && depth > click) {
                pressed = true;
                ++presses;
                button.offset = offset - drop;  // the surface gives way: the click
                client.commit(hc::Batch().modify(id, button));
                std::printf("pressed (%ld): depth %.3f mm, force %.3f N\n", presses, depth * 1e3,
                            n[0] * s.force[0] + n[1] * s.force[1] + n[2] * s.force[2]);
                std::fflush(stdout);
                if (max_presses > 0 && static_cast<double>(presses) >= max_presses) break;
            } else if (pressed && depth < release) {
                pressed = false;
                button.offset = offset;
                client.commit(hc::Batch().modify(id, button));
                std::printf("released: depth %.3f mm\n", depth * 1e3);
                std::fflush(stdout);
            }
            if (now - last_heartbeat > std::chrono::milliseconds(150)) {  // a third of the lease
                client.heartbeat();
                last_heartbeat = now;
            }
        }
        std::printf("push_button: %ld press(es)\n", presses);
        client.bye();
        return 0;
    } catch (const hc::Error& e) {
        std::fprintf(stderr, "push_button: %s\n", e.what());
        return examples::exit_code(e, connected);
    }
}
