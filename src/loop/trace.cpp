// SPDX-License-Identifier: Apache-2.0
#include "loop/trace.hpp"

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

namespace hapticd {

const char* TraceWriter::header() noexcept {
    return "tick,time_s,position_m,wall_force_N,external_force_N,wake_latency_us\n";
}

TraceWriter::TraceWriter(const std::string& path, std::size_t capacity, bool blocking)
    : path_(path), ring_(capacity), blocking_(blocking) {
    file_ = std::fopen(path.c_str(), "w");
    if (file_ == nullptr) {
        throw std::runtime_error("trace: cannot open '" + path + "' for writing: " + std::strerror(errno));
    }
    if (std::fputs(header(), file_) < 0) {
        write_error_ = true;
    }
    thread_ = std::thread([this] { run(); });
}

TraceWriter::~TraceWriter() { close(); }

std::size_t TraceWriter::drain() noexcept {
    TraceRecord r;
    std::size_t n = 0;
    while (ring_.try_pop(r)) {
        // %.17g round-trips doubles exactly; time_s is a whole number of ns.
        if (std::fprintf(file_, "%llu,%.9f,%.17g,%.17g,%.17g,%.3f\n", static_cast<unsigned long long>(r.tick), r.time_s,
                         r.position_m, r.wall_force_N, r.external_force_N, r.wake_latency_us) < 0) {
            write_error_.store(true, std::memory_order_relaxed);
        }
        ++n;
    }
    written_.fetch_add(n, std::memory_order_relaxed);
    return n;
}

void TraceWriter::run() noexcept {
    while (!stop_.load(std::memory_order_acquire)) {
        if (drain() == 0) {
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
    }
    drain();  // everything pushed before stop_ was set
}

bool TraceWriter::close() noexcept {
    if (closed_) {
        return !write_error();
    }
    closed_ = true;
    stop_.store(true, std::memory_order_release);
    if (thread_.joinable()) {
        thread_.join();
    }
    if (file_ != nullptr) {
        if (std::fflush(file_) != 0) write_error_ = true;
        if (std::fclose(file_) != 0) write_error_ = true;
        file_ = nullptr;
    }
    return !write_error();
}

}  // namespace hapticd
