// SPDX-License-Identifier: Apache-2.0
// The options of the examples: `--key value` pairs of numbers or comma-separated vectors, with defaults.
// Unknown keys and malformed values end the program with exit code 2 and a message naming them.
#pragma once

#include <array>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <map>
#include <sstream>
#include <string>

namespace examples {

class Options {
  public:
    Options(int argc, char** argv, std::map<std::string, std::string> defaults) : values_(std::move(defaults)) {
        for (int i = 1; i < argc; ++i) {
            const std::string key = argv[i];
            if (key == "--help") {
                std::cout << "options (default):\n";
                for (const auto& [k, v] : values_) std::cout << "  --" << k << " " << v << "\n";
                std::exit(0);
            }
            if (key.rfind("--", 0) != 0 || values_.count(key.substr(2)) == 0 || i + 1 >= argc) {
                fail("unknown option or missing value: '" + key + "' (--help lists them)");
            }
            values_[key.substr(2)] = argv[++i];
        }
    }
    [[nodiscard]] std::string text(const std::string& key) const { return values_.at(key); }
    [[nodiscard]] double number(const std::string& key) const {
        const std::string& s = values_.at(key);
        char* end = nullptr;
        const double v = std::strtod(s.c_str(), &end);
        if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v))
            fail("--" + key + " = '" + s + "' is not a finite number");
        return v;
    }
    [[nodiscard]] std::array<double, 3> vec3(const std::string& key) const {
        std::array<double, 3> v{};
        std::istringstream in(values_.at(key));
        std::string item;
        std::size_t n = 0;
        while (std::getline(in, item, ',')) {
            char* end = nullptr;
            const double x = std::strtod(item.c_str(), &end);
            if (n >= 3 || item.empty() || end != item.c_str() + item.size() || !std::isfinite(x)) n = 4;
            if (n < 3) v[n] = x;
            ++n;
        }
        if (n != 3) fail("--" + key + " = '" + values_.at(key) + "' must be 3 comma-separated numbers");
        return v;
    }

  private:
    [[noreturn]] static void fail(const std::string& message) {
        std::cerr << "example: " << message << "\n";
        std::exit(2);
    }
    std::map<std::string, std::string> values_;
};

}  // namespace examples

#include <csignal>

#include "hapticd/client.hpp"

namespace examples {

// Exit codes of the examples: 0 ok, 2 usage, 3 cannot connect, 5 refused by the daemon, 8 session lost.
inline int exit_code(const hapticd::client::Error& e, bool connected) {
    using hapticd::client::ErrorCode;
    if (e.code() == ErrorCode::Transport) return connected ? 8 : 3;
    if (e.code() == ErrorCode::LeaseLost || e.code() == ErrorCode::SlowConsumer) return 8;
    return 5;
}

inline volatile std::sig_atomic_t g_stop = 0;
inline void on_stop(int) { g_stop = 1; }
inline void install_stop_handlers() {
    std::signal(SIGINT, on_stop);
    std::signal(SIGTERM, on_stop);
}

}  // namespace examples
