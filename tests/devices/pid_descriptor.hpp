// SPDX-License-Identifier: Apache-2.0
// A HID PID report descriptor laid out like OpenFFBoard's default 2-axis one (Firmware/FFBoard/Inc/
// ffb_defs.h report ids: Set Effect 0x01, Set Constant Force 0x05, Effect Operation 0x0A, Block Free
// 0x0B, Device Control 0x0C, Device Gain 0x0D, Create New Effect 0x11, Block Load 0x12; input report 1
// with 64 button bits, then X and Y), written here from the HID 1.11 item encoding and the PID 1.0
// usages, for the tests and the emulated device. Resulting sizes, worked out by hand from the items
// below: input report 1 = 1 + 8 + 2 * 2 = 13 bytes (X at byte 9; with 32-bit axes 1 + 8 + 2 * 4 = 17);
// Set Effect = 1 + 1 + 1 + 4 * 2 + 1 + 1 + 1 + 2 * 2 + 2 * 2 = 22 bytes; Set Constant Force = 4 bytes.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <vector>

namespace hapticd::test {

class DescriptorBuilder {
  public:
    // Short item with the smallest size that holds `value` (signed for the logical limits).
    DescriptorBuilder& item(std::uint8_t tag_type, long value, bool is_signed = false) {
        int bytes = 0;
        if (value != 0 || tag_type == 0xA0 /* Collection needs its byte */) bytes = 1;
        if (is_signed ? (value < -128 || value > 127) : (value > 0xFF)) bytes = 2;
        if (is_signed ? (value < -32768 || value > 32767) : (value > 0xFFFF)) bytes = 4;
        data.push_back(static_cast<std::uint8_t>(tag_type | (bytes == 4 ? 3 : bytes)));
        for (int i = 0; i < bytes; ++i)
            data.push_back(static_cast<std::uint8_t>((static_cast<unsigned long>(value) >> (8 * i)) & 0xFF));
        return *this;
    }
    DescriptorBuilder& page(long v) { return item(0x04, v); }
    DescriptorBuilder& use(long v) { return item(0x08, v); }
    DescriptorBuilder& use_min(long v) { return item(0x18, v); }
    DescriptorBuilder& use_max(long v) { return item(0x28, v); }
    DescriptorBuilder& lmin(long v) { return item(0x14, v, true); }
    DescriptorBuilder& lmax(long v) { return item(0x24, v, true); }
    DescriptorBuilder& size(long v) { return item(0x74, v); }
    DescriptorBuilder& count(long v) { return item(0x94, v); }
    DescriptorBuilder& id(long v) { return item(0x84, v); }
    DescriptorBuilder& input(long flags) { return item(0x80, flags); }
    DescriptorBuilder& output(long flags) { return item(0x90, flags); }
    DescriptorBuilder& feature(long flags) { return item(0xB0, flags); }
    DescriptorBuilder& collection(long kind) { return item(0xA0, kind); }
    DescriptorBuilder& end() {
        data.push_back(0xC0);
        return *this;
    }
    std::vector<std::uint8_t> data;
};

inline constexpr long kVar = 0x02;    // Data, Variable, Absolute
inline constexpr long kArray = 0x00;  // Data, Array, Absolute
inline constexpr long kConst = 0x01;  // Constant (padding)

inline std::vector<std::uint8_t> openffboard_like_descriptor(bool axes_32_bit = false) {
    DescriptorBuilder b;
    b.page(0x01).use(0x04).collection(0x01);  // Generic Desktop, Joystick, Application
    // Input report 1: 64 buttons, X, Y.
    b.id(1).page(0x09).use_min(1).use_max(64).lmin(0).lmax(1).size(1).count(64).input(kVar);
    b.page(0x01).use(0x30).use(0x31);
    if (axes_32_bit) {
        b.lmin(-0x7FFFFFFF).lmax(0x7FFFFFFF).size(32).count(2).input(kVar);
    } else {
        b.lmin(-32767).lmax(32767).size(16).count(2).input(kVar);
    }
    b.page(0x0F);  // PID
    // Set Effect report (output 1).
    b.use(0x21).collection(0x02).id(1);
    b.use(0x22).lmin(1).lmax(40).size(8).count(1).output(kVar);  // effect block index
    b.use(0x25).collection(0x02);                                // effect type
    b.use(0x26).use(0x27).use(0x30).use(0x31).use(0x40).lmin(1).lmax(5).size(8).count(1).output(kArray);
    b.end();
    b.use(0x50).use(0x54).use(0x51).use(0xA7).lmin(0).lmax(32767).size(16).count(4).output(kVar);
    b.use(0x52).lmin(0).lmax(255).size(8).count(1).output(kVar);  // gain
    b.use(0x53).lmin(1).lmax(8).size(8).count(1).output(kVar);    // trigger button
    b.use(0x55).collection(0x02);                                 // axes enable
    b.page(0x01).use(0x30).use(0x31).lmin(0).lmax(1).size(1).count(2).output(kVar);
    b.end();
    b.page(0x0F).use(0x56).count(1).output(kVar);  // direction enable
    b.count(5).output(kConst);                     // padding
    b.use(0x57).collection(0x02);                  // direction
    b.page(0x0A).use(1).use(2).lmin(0).lmax(35999).size(16).count(2).output(kVar);
    b.end();
    b.page(0x0F).use(0x58).collection(0x02);  // type specific block offset
    b.page(0x0A).use(1).use(2).lmin(0).lmax(32767).size(16).count(2).output(kVar);
    b.end();
    b.page(0x0F).end();
    // Set Constant Force report (output 5).
    b.use(0x73).collection(0x02).id(5);
    b.use(0x22).lmin(1).lmax(40).size(8).count(1).output(kVar);
    b.use(0x70).lmin(-32767).lmax(32767).size(16).count(1).output(kVar);
    b.end();
    // Effect Operation report (output 0x0A).
    b.use(0x77).collection(0x02).id(0x0A);
    b.use(0x22).lmin(1).lmax(40).size(8).count(1).output(kVar);
    b.use(0x78).collection(0x02);
    b.use(0x79).use(0x7A).use(0x7B).lmin(1).lmax(3).size(8).count(1).output(kArray);
    b.end();
    b.use(0x7C).lmin(0).lmax(255).size(8).count(1).output(kVar);
    b.end();
    // Block Free report (output 0x0B).
    b.use(0x90).collection(0x02).id(0x0B);
    b.use(0x22).lmin(1).lmax(40).size(8).count(1).output(kVar);
    b.end();
    // Device Control (output 0x0C).
    b.use(0x95).collection(0x02).id(0x0C);
    b.use(0x96).collection(0x02);
    b.use(0x97).use(0x98).use(0x99).use(0x9A).use(0x9B).use(0x9C).lmin(1).lmax(6).size(8).count(1).output(kArray);
    b.end();
    b.end();
    // Device Gain (output 0x0D).
    b.use(0x7D).collection(0x02).id(0x0D);
    b.use(0x7E).lmin(0).lmax(255).size(8).count(1).output(kVar);
    b.end();
    // Create New Effect (feature 0x11).
    b.use(0xAB).collection(0x02).id(0x11);
    b.use(0x25).collection(0x02);
    b.use(0x26).use(0x27).use(0x30).use(0x31).use(0x40).lmin(1).lmax(5).size(8).count(1).feature(kArray);
    b.end();
    b.use(0xAC).lmin(0).lmax(65535).size(16).count(1).feature(kVar);
    b.end();
    // PID Block Load (feature 0x12).
    b.use(0x89).collection(0x02).id(0x12);
    b.use(0x22).lmin(1).lmax(40).size(8).count(1).feature(kVar);
    b.use(0x8B).collection(0x02);
    b.use(0x8C).use(0x8D).use(0x8E).lmin(1).lmax(3).size(8).count(1).feature(kArray);
    b.end();
    b.use(0xAC).lmin(0).lmax(65535).size(16).count(1).feature(kVar);
    b.end();
    b.end();  // application
    return b.data;
}

}  // namespace hapticd::test
