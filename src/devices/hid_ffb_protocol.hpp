// USB HID force-feedback (HID PID) reports used by hapticd, as pure encode/decode functions.
//
// Report layouts: USB HID "Device Class Definition for Physical Interface Devices (PID) 1.0" (Set Effect,
// Set Constant Force, Effect Operation, Create New Effect, PID Block Load, PID Device Control reports),
// with the report ids and field sizes of OpenFFBoard (Ultrawipf/OpenFFBoard Firmware/FFBoard/Inc/ffb_defs.h:
// HID_ID_EFFREP 0x01, HID_ID_CONSTREP 0x05, HID_ID_EFOPREP 0x0A, HID_ID_BLKFRREP 0x0B, HID_ID_CTRLREP 0x0C,
// HID_ID_NEWEFREP 0x11, HID_ID_BLKLDREP 0x12; FFB_SetEffect_t, FFB_SetConstantForce_Data_t, reportHID_t:
// id 1, 32 button bits, then int16 X at byte 5). All multi-byte fields little-endian (USB HID).
// Every id, offset and scale can be overridden in the device profile (config/devices/*.toml).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace hapticd::hid {

struct Layout {
    std::uint16_t vendor_id = 0x1209;
    std::uint16_t product_id = 0xFFB0;
    // Position: an axis of an input report.
    std::uint8_t input_report_id = 0x01;
    std::size_t position_offset = 5;   // byte offset in the report, report id byte = offset 0
    std::size_t position_bytes = 2;    // 1, 2 or 4
    bool position_signed = true;
    double position_scale = 1.0;       // position units (m or rad) per count
    double position_zero = 0.0;        // count at position 0
    // Force: a constant-force effect.
    std::uint8_t set_effect_report_id = 0x01;
    std::uint8_t constant_force_report_id = 0x05;
    std::uint8_t effect_operation_report_id = 0x0A;
    std::uint8_t block_free_report_id = 0x0B;
    std::uint8_t device_control_report_id = 0x0C;
    std::uint8_t create_effect_report_id = 0x11;  // feature report
    std::uint8_t block_load_report_id = 0x12;     // feature report
    double force_scale = 1.0;          // magnitude counts per N (N m)
    std::int32_t force_max_counts = 10000;  // logical maximum of the Magnitude usage
};

// PID usage values (HID PID 1.0: ET Constant Force is effect type 1 in the Set Effect report's array;
// Effect Operation: Start 1, Start Solo 2, Stop 3; Device Control: Enable Actuators 1, Disable 2,
// Stop All Effects 3, Reset 4; Block Load Status: Success 1, Full 2, Error 3).
inline constexpr std::uint8_t kEffectTypeConstant = 1;
enum class EffectOperation : std::uint8_t { Start = 1, StartSolo = 2, Stop = 3 };
enum class DeviceControl : std::uint8_t { EnableActuators = 1, DisableActuators = 2, StopAll = 3, Reset = 4 };
inline constexpr std::uint8_t kBlockLoadSuccess = 1;

// Position of an input report; false (and nothing written) if the id or the length does not match.
bool decode_position(const std::uint8_t* report, std::size_t size, const Layout& layout, double& position) noexcept;

// Set Constant Force report: [id, block, magnitude int16 LE]. The magnitude is force * force_scale
// rounded and clamped to +-force_max_counts (and int16); `saturated` tells whether it was clamped.
std::array<std::uint8_t, 4> encode_constant_force(double force, std::uint8_t block, const Layout& layout,
                                                  bool& saturated) noexcept;

// Set Effect report (OpenFFBoard FFB_SetEffect_t, 16 bytes): constant force, infinite duration
// (0xFFFF, the PID null value), gain 255, no trigger button (0xFF), X axis enabled, direction 0.
std::array<std::uint8_t, 16> encode_set_effect(std::uint8_t block, const Layout& layout) noexcept;

std::array<std::uint8_t, 4> encode_effect_operation(std::uint8_t block, EffectOperation op, const Layout& layout) noexcept;
std::array<std::uint8_t, 2> encode_device_control(DeviceControl control, const Layout& layout) noexcept;
std::array<std::uint8_t, 2> encode_block_free(std::uint8_t block, const Layout& layout) noexcept;
// Create New Effect feature report: [id, effect type, byte count u16 LE = 0].
std::array<std::uint8_t, 4> encode_create_effect(const Layout& layout) noexcept;
// PID Block Load feature report: [id, block, status, ram pool u16]; false if malformed or not Success.
bool decode_block_load(const std::uint8_t* report, std::size_t size, const Layout& layout, std::uint8_t& block) noexcept;

}  // namespace hapticd::hid
