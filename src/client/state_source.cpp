// SPDX-License-Identifier: Apache-2.0
// StateSource: the shared memory or the subscription (docs/clients.md, "Remote use").
#include <cmath>
#include <stdexcept>
#include <string>

#include "hapticd/client.hpp"

namespace hapticd::client {

StateSource::StateSource(Client& client, double rate_hz, Mode mode) : client_(&client) {
    if (!(rate_hz >= 0.1 && rate_hz <= 1000.0)) {
        throw std::invalid_argument("StateSource: rate_hz = " + std::to_string(rate_hz) +
                                    " is invalid; accepted range: 0.1 .. 1000");
    }
    if (mode == Mode::SharedMemory || (mode == Mode::Auto && !client.stream())) {
        try {
            reader_.emplace(StateReader::open(client.welcome().state_shm));
        } catch (const Error& e) {
            if (mode == Mode::SharedMemory) throw;
            why_ = std::string("the shared memory cannot be opened here (") + e.what() + ")";
        }
    } else if (mode == Mode::Auto) {
        why_ = "the stream transport (the daemon may be on another machine)";
    }
    if (!reader_) client.subscribe(rate_hz);
}

std::optional<StateSample> StateSource::read(double timeout_s) {
    if (reader_) {
        StateSample s;
        if (!reader_->read(s)) return std::nullopt;
        return s;
    }
    return client_->latest_state(timeout_s);
}

}  // namespace hapticd::client
