// SPDX-License-Identifier: Apache-2.0
#include "devices/hid_report_descriptor.hpp"

#include <array>
#include <map>
#include <utility>

namespace hapticd::hid {

namespace {

struct GlobalState {
    std::uint16_t usage_page = 0;
    std::int32_t logical_min = 0;
    std::int32_t logical_max = 0;
    std::uint32_t logical_max_raw = 0;
    std::uint32_t logical_max_size = 0;
    std::uint32_t report_size = 0;
    std::uint32_t report_count = 0;
    std::uint8_t report_id = 0;
};

std::int32_t sign_extend(std::uint32_t raw, std::uint32_t bytes) noexcept {
    if (bytes == 0) return 0;
    if (bytes >= 4) return static_cast<std::int32_t>(raw);
    const std::uint32_t bits = 8 * bytes;
    const std::uint32_t sign = 1U << (bits - 1);
    return static_cast<std::int32_t>((raw ^ sign) - sign);
}

constexpr std::size_t kMaxFields = 4096;
constexpr std::uint32_t kMaxReportBits = 4096 * 8;

}  // namespace

std::size_t ReportDescriptor::report_bytes(ReportType type, std::uint8_t report_id) const noexcept {
    std::uint32_t bits = 0;
    bool any = false;
    for (const ReportField& f : fields) {
        if (f.type != type || f.report_id != report_id) continue;
        any = true;
        bits = std::max(bits, f.bit_offset + f.bit_size * f.count);
    }
    if (!any) return 0;
    return (uses_report_ids ? 1U : 0U) + (bits + 7) / 8;
}

const ReportField* ReportDescriptor::find(ReportType type, std::uint32_t collection,
                                          std::uint32_t wanted) const noexcept {
    for (const ReportField& f : fields) {
        if (f.type == type && !f.array && f.usage == wanted && (collection == 0 || f.collection == collection))
            return &f;
    }
    return nullptr;
}

const ReportField* ReportDescriptor::find_array(ReportType type, std::uint32_t collection,
                                                std::uint32_t selector) const noexcept {
    for (const ReportField& f : fields) {
        if (f.type != type || !f.array || (collection != 0 && f.collection != collection)) continue;
        for (std::uint32_t u : f.usages) {
            if (u == selector) return &f;
        }
    }
    return nullptr;
}

bool parse_report_descriptor(const std::uint8_t* data, std::size_t size, ReportDescriptor& out, std::string& error) {
    out = ReportDescriptor{};
    GlobalState g;
    std::vector<GlobalState> stack;
    std::vector<std::uint32_t> usages;  // local: Usage items (and expanded min..max ranges)
    std::uint32_t usage_min = 0;
    bool have_usage_min = false;
    std::vector<std::uint32_t> collections;                 // usages of the open collections
    std::map<std::pair<int, int>, std::uint32_t> next_bit;  // (type, id) -> next free bit

    auto full_usage = [&g](std::uint32_t raw, std::uint32_t bytes) {
        return bytes == 4 ? raw : usage(g.usage_page, static_cast<std::uint16_t>(raw));
    };
    std::size_t i = 0;
    while (i < size) {
        const std::size_t at = i;
        const std::uint8_t prefix = data[i++];
        if (prefix == 0xFE) {  // long item: bDataSize, bLongItemTag, data
            if (i + 2 > size || i + 2 + data[i] > size) {
                error = "parse_report_descriptor: long item at byte " + std::to_string(at) + " runs past the end";
                return false;
            }
            i += 2 + data[i];
            continue;
        }
        static constexpr std::array<std::uint32_t, 4> kSizes{0, 1, 2, 4};
        const std::uint32_t bytes = kSizes[prefix & 3U];
        if (i + bytes > size) {
            error = "parse_report_descriptor: item at byte " + std::to_string(at) + " runs past the end";
            return false;
        }
        std::uint32_t raw = 0;
        for (std::uint32_t b = 0; b < bytes; ++b) raw |= static_cast<std::uint32_t>(data[i + b]) << (8 * b);
        i += bytes;
        const unsigned type = (prefix >> 2) & 3U;
        const unsigned tag = prefix >> 4;
        if (type == 1) {  // global
            switch (tag) {
                case 0x0:
                    g.usage_page = static_cast<std::uint16_t>(raw);
                    break;
                case 0x1:
                    g.logical_min = sign_extend(raw, bytes);
                    break;
                case 0x2:
                    g.logical_max = sign_extend(raw, bytes);
                    g.logical_max_raw = raw;
                    g.logical_max_size = bytes;
                    break;
                case 0x7:
                    if (raw > 32) {
                        error = "parse_report_descriptor: Report Size " + std::to_string(raw) + " at byte " +
                                std::to_string(at) + " (accepted: 1..32)";
                        return false;
                    }
                    g.report_size = raw;
                    break;
                case 0x8:
                    g.report_id = static_cast<std::uint8_t>(raw);
                    out.uses_report_ids = true;
                    break;
                case 0x9:
                    g.report_count = raw;
                    break;
                case 0xA:
                    stack.push_back(g);
                    break;
                case 0xB:
                    if (stack.empty()) {
                        error = "parse_report_descriptor: Pop without Push at byte " + std::to_string(at);
                        return false;
                    }
                    g = stack.back();
                    stack.pop_back();
                    break;
                default:
                    break;  // physical range, units: not needed
            }
            continue;
        }
        if (type == 2) {  // local
            if (tag == 0x0) {
                usages.push_back(full_usage(raw, bytes));
            } else if (tag == 0x1) {
                usage_min = full_usage(raw, bytes);
                have_usage_min = true;
            } else if (tag == 0x2 && have_usage_min) {
                const std::uint32_t usage_max = full_usage(raw, bytes);
                for (std::uint32_t u = usage_min; u <= usage_max && usages.size() < kMaxFields; ++u)
                    usages.push_back(u);
                have_usage_min = false;
            }
            continue;
        }
        if (type != 0) {
            error = "parse_report_descriptor: reserved item type at byte " + std::to_string(at);
            return false;
        }
        // Main items.
        if (tag == 0xA) {  // Collection
            collections.push_back(usages.empty() ? 0 : usages.front());
        } else if (tag == 0xC) {  // End Collection
            if (collections.empty()) {
                error = "parse_report_descriptor: End Collection without Collection at byte " + std::to_string(at);
                return false;
            }
            collections.pop_back();
        } else if (tag == 0x8 || tag == 0x9 || tag == 0xB) {  // Input, Output, Feature
            const ReportType rt =
                tag == 0x8 ? ReportType::Input : (tag == 0x9 ? ReportType::Output : ReportType::Feature);
            std::uint32_t& bit = next_bit[{static_cast<int>(rt), g.report_id}];
            const bool constant = (raw & 1U) != 0;
            const bool variable = (raw & 2U) != 0;
            // In 64 bits: a Report Count of up to 2^32 - 1 times a size of 32 overflows 32 (found by the fuzz target:
            // the wrapped product passed this check and the loop below made 2^28 fields).
            const std::uint64_t total64 = std::uint64_t{g.report_size} * g.report_count;
            if (std::uint64_t{bit} + total64 > kMaxReportBits) {
                error = "parse_report_descriptor: report " + std::to_string(g.report_id) +
                        " longer than 4096 bytes at byte " + std::to_string(at);
                return false;
            }
            const auto total = static_cast<std::uint32_t>(total64);
            // A logical maximum written in fewer bytes than needed for an unsigned value (e.g. 0xFF in one
            // byte) is read as unsigned when the minimum is not negative (as Linux's hid-core does).
            std::int32_t lmax = g.logical_max;
            if (g.logical_min >= 0 && lmax < g.logical_min && g.logical_max_size < 4)
                lmax = static_cast<std::int32_t>(g.logical_max_raw);
            const std::uint32_t collection = collections.empty() ? 0 : collections.back();
            const std::uint32_t parent = collections.size() < 2 ? 0 : collections[collections.size() - 2];
            if (!constant && g.report_size > 0 && g.report_count > 0) {
                if (variable) {
                    for (std::uint32_t k = 0; k < g.report_count; ++k) {
                        ReportField f;
                        f.type = rt;
                        f.report_id = g.report_id;
                        f.usage = usages.empty() ? 0 : usages[std::min<std::size_t>(k, usages.size() - 1)];
                        f.collection = collection;
                        f.parent_collection = parent;
                        f.bit_offset = bit + k * g.report_size;
                        f.bit_size = g.report_size;
                        f.logical_min = g.logical_min;
                        f.logical_max = lmax;
                        out.fields.push_back(std::move(f));
                    }
                } else {
                    ReportField f;
                    f.type = rt;
                    f.report_id = g.report_id;
                    f.collection = collection;
                    f.parent_collection = parent;
                    f.bit_offset = bit;
                    f.bit_size = g.report_size;
                    f.count = g.report_count;
                    f.logical_min = g.logical_min;
                    f.logical_max = lmax;
                    f.array = true;
                    f.usages = usages;
                    out.fields.push_back(std::move(f));
                }
            } else if (constant && total > 0) {
                // Padding still makes the report exist (and long): record it as an unnamed field.
                ReportField f;
                f.type = rt;
                f.report_id = g.report_id;
                f.collection = collection;
                f.bit_offset = bit;
                f.bit_size = g.report_size;
                f.count = g.report_count;
                f.array = true;  // never matched by find()
                out.fields.push_back(std::move(f));
            }
            bit += total;
            if (out.fields.size() > kMaxFields) {
                error = "parse_report_descriptor: more than 4096 fields";
                return false;
            }
        }
        usages.clear();
        have_usage_min = false;
    }
    if (!collections.empty()) {
        error = "parse_report_descriptor: " + std::to_string(collections.size()) + " collection(s) not closed";
        return false;
    }
    return true;
}

void put_field(std::uint8_t* report, std::size_t report_size, const ReportField& f, bool has_id_byte,
               std::int64_t value, std::uint32_t element) noexcept {
    const std::uint64_t bits = static_cast<std::uint64_t>(value);
    const std::size_t base = (has_id_byte ? 8U : 0U) + f.bit_offset + static_cast<std::size_t>(element) * f.bit_size;
    for (std::uint32_t b = 0; b < f.bit_size; ++b) {
        const std::size_t pos = base + b;
        if (pos / 8 >= report_size) return;
        const auto mask = static_cast<std::uint8_t>(1U << (pos % 8));
        if (((bits >> b) & 1U) != 0) {
            report[pos / 8] = static_cast<std::uint8_t>(report[pos / 8] | mask);
        } else {
            report[pos / 8] = static_cast<std::uint8_t>(report[pos / 8] & ~mask);
        }
    }
}

bool get_field(const std::uint8_t* report, std::size_t report_size, const ReportField& f, bool has_id_byte,
               std::int64_t& value, std::uint32_t element) noexcept {
    const std::size_t base = (has_id_byte ? 8U : 0U) + f.bit_offset + static_cast<std::size_t>(element) * f.bit_size;
    if (f.bit_size == 0 || f.bit_size > 32 || (base + f.bit_size + 7) / 8 > report_size) return false;
    std::uint64_t bits = 0;
    for (std::uint32_t b = 0; b < f.bit_size; ++b) {
        const std::size_t pos = base + b;
        if (((report[pos / 8] >> (pos % 8)) & 1U) != 0) bits |= std::uint64_t{1} << b;
    }
    if (f.logical_min < 0 && ((bits >> (f.bit_size - 1)) & 1U) != 0) bits |= ~std::uint64_t{0} << f.bit_size;
    value = static_cast<std::int64_t>(bits);
    return true;
}

}  // namespace hapticd::hid
