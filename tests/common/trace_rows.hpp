// SPDX-License-Identifier: Apache-2.0
// hapticd's --trace CSV (one axis: tick, time, position, force, external force, latency) read back by the process
// tests; a malformed line is a test failure.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace hapticd::test {

struct TraceRow {
    unsigned long long tick;
    double time, position, force, external, latency;
};

inline std::vector<TraceRow> read_trace(const std::string& path) {
    std::vector<TraceRow> rows;
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
        TraceRow r{};
        if (std::sscanf(line.c_str(), "%llu,%lf,%lf,%lf,%lf,%lf", &r.tick, &r.time, &r.position, &r.force, &r.external,
                        &r.latency) == 6) {
            rows.push_back(r);
        } else {
            ADD_FAILURE() << "malformed trace line: " << line;
        }
    }
    return rows;
}

}  // namespace hapticd::test
