// SPDX-License-Identifier: Apache-2.0
// Progress of the long experiment runs on stderr: one line rewritten in place ('\r') when stderr is a
// terminal, otherwise a plain line at most every `plain_interval` seconds (and at the end); nothing when
// quiet. Called between trials, never from the real-time loop.
#pragma once

#include <chrono>
#include <cstddef>
#include <ostream>
#include <string>
#include <string_view>

namespace hapticd::experiment {

class Progress {
  public:
    Progress(std::ostream& out, bool interactive, bool quiet, double plain_interval = 2.0);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    void start(std::string_view task, std::size_t total);
    // done of total trials, with a short description of the last one.
    void update(std::size_t done, std::string_view detail);
    // The planned total grew (bisection steps are not known in advance).
    void set_total(std::size_t total) { total_ = total; }
    void finish(std::string_view summary);

    // Whether stderr is a terminal (isatty).
    static bool stderr_is_terminal() noexcept;

  private:
    void emit(bool force);
    std::ostream& out_;
    bool interactive_, quiet_;
    double interval_;
    std::string task_, detail_;
    std::size_t done_ = 0, total_ = 0, last_width_ = 0;
    bool open_line_ = false;
    std::chrono::steady_clock::time_point begin_, last_emit_;
};

}  // namespace hapticd::experiment
