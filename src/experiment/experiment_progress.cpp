// SPDX-License-Identifier: Apache-2.0
#include "experiment/experiment_progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace hapticd::experiment {

Progress::Progress(std::ostream& out, bool interactive, bool quiet, double plain_interval)
    : out_(out), interactive_(interactive), quiet_(quiet), interval_(plain_interval) {}

Progress::~Progress() {
    if (open_line_) out_ << "\n" << std::flush;
}

bool Progress::stderr_is_terminal() noexcept { return ::isatty(STDERR_FILENO) == 1; }

void Progress::start(std::string_view task, std::size_t total) {
    task_ = task;
    total_ = total;
    done_ = 0;
    detail_.clear();
    begin_ = last_emit_ = std::chrono::steady_clock::now();
    emit(true);
}

void Progress::update(std::size_t done, std::string_view detail) {
    done_ = done;
    detail_ = detail;
    emit(false);
}

void Progress::finish(std::string_view summary) {
    detail_ = summary;
    emit(true);
    if (open_line_ && !quiet_) out_ << "\n" << std::flush;
    open_line_ = false;
}

void Progress::emit(bool force) {
    if (quiet_) return;
    const auto now = std::chrono::steady_clock::now();
    const double since = std::chrono::duration<double>(now - last_emit_).count();
    if (!force && !interactive_ && since < interval_) return;
    if (!force && interactive_ && since < 0.05) return;  // at most ~20 redraws per second
    last_emit_ = now;
    const double elapsed = std::chrono::duration<double>(now - begin_).count();
    char head[160];
    std::snprintf(head, sizeof head, "hapticd experiment %s: %zu/%zu trials, %.1f s", task_.c_str(), done_,
                  std::max(total_, done_), elapsed);
    std::string line = std::string(head) + (detail_.empty() ? "" : "; " + detail_);
    if (interactive_) {
        const std::size_t width = line.size();
        if (width < last_width_) line.append(last_width_ - width, ' ');
        last_width_ = width;
        out_ << "\r" << line << std::flush;
        open_line_ = true;
    } else {
        out_ << line << "\n" << std::flush;
    }
}

}  // namespace hapticd::experiment
