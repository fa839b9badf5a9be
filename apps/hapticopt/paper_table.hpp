// SPDX-License-Identifier: Apache-2.0
// Tables III and IV of Hulin et al. (IROS 2011) as printed, parsed from the embedded CSV.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hapticopt::cli {

/// A printed number with its printed precision (unit of the last digit).
struct PrintedValue {
    double value = 0;
    double unit = 1;  ///< 10^-decimals
};

struct PaperRow {
    std::string table;  ///< "III" or "IV"
    double delay = 0;
    std::string criterion;  ///< amax, OV, CE0, ..., CE2+OV
    double gamma = 0;
    double delta = 0;
    PrintedValue alpha;
    PrintedValue beta;
    std::optional<PrintedValue> cost;  ///< none printed for amax
};

/// Parses "table,delay,criterion,gamma,delta,alpha_opt,beta_opt,cost" lines ('#' comments, one
/// header line). Throws std::runtime_error naming the line on malformed input.
std::vector<PaperRow> parse_paper_table(std::string_view csv);

/// The 64 rows embedded at build time from tests/data/paper_tables.csv.
const std::vector<PaperRow>& paper_rows();

}  // namespace hapticopt::cli
