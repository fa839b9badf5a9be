// SPDX-License-Identifier: Apache-2.0
// USB HID report descriptor parser: where each field of each report is, so that hapticd reads the
// position and writes the force-feedback (PID) reports at the offsets, lengths and logical ranges the
// device itself declares, instead of offsets fixed for one firmware version.
//
// Source: USB "Device Class Definition for HID 1.11", Sect. 6.2.2 (short items: prefix byte = tag << 4 |
// type << 2 | size code; main items Input 0x8, Output 0x9, Feature 0xB, Collection 0xA, End Collection
// 0xC; global items Usage Page 0x0, Logical Minimum 0x1, Logical Maximum 0x2, Report Size 0x7, Report
// ID 0x8, Report Count 0x9, Push 0xA, Pop 0xB; local items Usage 0x0, Usage Minimum 0x1, Usage Maximum
// 0x2; long items 0xFE are skipped). Fields are laid out in declaration order per (report type, report
// id), least significant bit first; with report ids, byte 0 of every report is its id.
// Cost: one pass over the descriptor (at most a few hundred bytes); allocation only here, at open().
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace hapticd::hid {

enum class ReportType : std::uint8_t { Input, Output, Feature };

// A usage with its page: page << 16 | id.
constexpr std::uint32_t usage(std::uint16_t page, std::uint16_t id) noexcept {
    return static_cast<std::uint32_t>(page) << 16 | id;
}

struct ReportField {
    ReportType type = ReportType::Input;
    std::uint8_t report_id = 0;
    std::uint32_t usage = 0;              // variable field: its usage; array field: 0
    std::uint32_t collection = 0;         // usage of the innermost enclosing collection (0: none)
    std::uint32_t parent_collection = 0;  // usage of the collection around that one
    std::uint32_t bit_offset = 0;         // from the first bit after the report id byte
    std::uint32_t bit_size = 0;           // per element
    std::uint32_t count = 1;              // elements (variable fields: 1 per usage)
    std::int32_t logical_min = 0;
    std::int32_t logical_max = 0;
    bool array = false;                 // array (selector) field: value = logical_min + index in `usages`
    std::vector<std::uint32_t> usages;  // array fields: the selectable usages, in order
};

struct ReportDescriptor {
    std::vector<ReportField> fields;
    bool uses_report_ids = false;

    // Length in bytes of a report as written/read through hidraw (including the id byte if ids are
    // used); 0 if no such report.
    [[nodiscard]] std::size_t report_bytes(ReportType type, std::uint8_t report_id) const noexcept;
    // The first variable field with `usage` inside a collection with usage `collection` (0: any).
    [[nodiscard]] const ReportField* find(ReportType type, std::uint32_t collection,
                                          std::uint32_t usage) const noexcept;
    // The first array field of `type` inside `collection` that offers `selector`.
    [[nodiscard]] const ReportField* find_array(ReportType type, std::uint32_t collection,
                                                std::uint32_t selector) const noexcept;
};

// Parses `size` bytes; false (with `error` naming the byte offset and the cause) if the descriptor is
// malformed: truncated item, unbalanced collections, Pop without Push, Report Size > 32, report longer
// than 4096 bits, or more than 4096 fields.
bool parse_report_descriptor(const std::uint8_t* data, std::size_t size, ReportDescriptor& out, std::string& error);

// Writes `value` into the field's bits (element `element`) of a report buffer that starts with the
// report id byte when the descriptor uses ids. Values are truncated to the field's size (two's
// complement for negative values). No bounds beyond `report_size` are written.
void put_field(std::uint8_t* report, std::size_t report_size, const ReportField& field, bool has_id_byte,
               std::int64_t value, std::uint32_t element = 0) noexcept;
// Reads a field (sign-extended when logical_min < 0). false if the report is too short.
bool get_field(const std::uint8_t* report, std::size_t report_size, const ReportField& field, bool has_id_byte,
               std::int64_t& value, std::uint32_t element = 0) noexcept;

}  // namespace hapticd::hid
