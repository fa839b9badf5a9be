// SPDX-License-Identifier: Apache-2.0
// Uses the installed client library without a daemon: builds a batch, and gets the documented typed
// errors for a socket and a shared-memory state that do not exist.
#include <cstdio>

#include <hapticd/client.hpp>

int main() {
    namespace cl = hapticd::client;
    cl::Batch batch;
    batch
        .add(cl::Plane{.normal = {0, 0, 1}, .offset = 0.0, .bilateral = false, .gains = cl::Gains::by_criterion("CE2")})
        .remove(7)
        .clear();
    int failures = batch.operations().size() == 3 ? 0 : 1;
    try {
        (void)cl::Client::connect({.socket_path = "/nonexistent/hapticd.sock", .timeout_s = 0.1});
        ++failures;
    } catch (const cl::Error& e) {
        failures += e.code() == cl::ErrorCode::Transport ? 0 : 1;
    }
    try {
        (void)cl::StateReader::open("/hapticd-client-consumer-nonexistent");
        ++failures;
    } catch (const cl::Error& e) {
        failures += e.code() == cl::ErrorCode::Transport ? 0 : 1;
    }
    std::printf("hapticd client consumer: protocol %d, %d failures\n", cl::kProtocolVersion, failures);
    return failures == 0 ? 0 : 1;
}
