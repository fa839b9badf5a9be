// SPDX-License-Identifier: Apache-2.0
#include "paper_table.hpp"

#include <sstream>
#include <stdexcept>

#include "paper_tables_csv.hpp"

namespace hapticopt::cli {
namespace {

PrintedValue printed(const std::string& text, int line) {
    std::size_t used = 0;
    PrintedValue v;
    try {
        v.value = std::stod(text, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used != text.size() || text.empty()) {
        throw std::runtime_error("paper table line " + std::to_string(line) + ": not a number: '" + text + "'");
    }
    const auto dot = text.find('.');
    const std::size_t decimals = dot == std::string::npos ? 0 : text.size() - dot - 1;
    v.unit = 1;
    for (std::size_t i = 0; i < decimals; ++i) v.unit /= 10;
    return v;
}

}  // namespace

std::vector<PaperRow> parse_paper_table(std::string_view csv) {
    std::vector<PaperRow> rows;
    std::istringstream in{std::string(csv)};
    std::string line;
    int number = 0;
    bool header = true;
    while (std::getline(in, line)) {
        ++number;
        if (line.empty() || line[0] == '#') continue;
        if (header) {
            header = false;
            continue;
        }
        std::vector<std::string> f;
        std::stringstream fields(line);
        std::string cell;
        while (std::getline(fields, cell, ',')) f.push_back(cell);
        if (f.size() == 7 && !line.empty() && line.back() == ',') f.emplace_back();
        if (f.size() != 8) {
            throw std::runtime_error("paper table line " + std::to_string(number) + ": expected 8 fields");
        }
        PaperRow r;
        r.table = f[0];
        r.delay = printed(f[1], number).value;
        r.criterion = f[2];
        r.gamma = printed(f[3], number).value;
        r.delta = printed(f[4], number).value;
        r.alpha = printed(f[5], number);
        r.beta = printed(f[6], number);
        if (!f[7].empty()) r.cost = printed(f[7], number);
        rows.push_back(std::move(r));
    }
    return rows;
}

const std::vector<PaperRow>& paper_rows() {
    static const std::vector<PaperRow> rows = parse_paper_table(kPaperTablesCsv);
    return rows;
}

}  // namespace hapticopt::cli
