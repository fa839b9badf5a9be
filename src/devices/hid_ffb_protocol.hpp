// SPDX-License-Identifier: Apache-2.0
// USB HID force-feedback (HID PID) reports used by hapticd, laid out from the device's own report
// descriptor (hid_report_descriptor.hpp): report ids, lengths, bit offsets and logical ranges are those
// the device declares, so that firmware versions with different layouts (OpenFFBoard's 32- or 64-bit
// button field before X, 8- or 16-bit directions, 16- or 32-bit axes) are all driven correctly.
//
// Usages: USB "Device Class Definition for PID 1.0" (usage page 0x0F): Set Effect Report 0x21 (Effect
// Block Index 0x22, Effect Type 0x25 with ET Constant Force 0x26, Duration 0x50, Sample Period 0x51,
// Gain 0x52, Trigger Button 0x53, Trigger Repeat Interval 0x54, Axes Enable 0x55, Direction Enable 0x56,
// Direction 0x57, Start Delay 0xA7), Set Constant Force Report 0x73 (Magnitude 0x70), Effect Operation
// Report 0x77 (0x78: Start 0x79, Start Solo 0x7A, Stop 0x7B; Loop Count 0x7C), Device Gain Report 0x7D
// (Device Gain 0x7E), Block Free Report 0x90, Device Control 0x96 (Enable Actuators 0x97, Disable 0x98,
// Stop All Effects 0x99, Reset 0x9A), Create New Effect Report 0xAB (Byte Count 0xAC), Block Load Report
// 0x89 (Block Load Status 0x8B: Success 0x8C, Full 0x8D, Error 0x8E). Position: Generic Desktop (0x01)
// X (0x30) of an Input report.
// What is written follows the Linux kernel's drivers/hid/usbhid/hid-pidff.c: at start Reset, then Stop
// All Effects (pidff_reset()), Device Gain to the maximum (pidff_set_gain(0xFFFF)), Enable Actuators;
// the Set Effect report always with Direction Enable set and a direction (pidff_set_effect_report());
// the direction is 90 deg (a quarter of the Direction field's logical range), so that firmware that
// takes the X component as magnitude * sin(direction) (OpenFFBoard EffectsCalculator, Firmware
// v1.14.3-v1.16.0 with DirectionEnable) gets the full magnitude. The SIGN of that component differs
// between firmware versions: `hapticd check-device` measures it (docs/devices.md).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "devices/hid_report_descriptor.hpp"

namespace hapticd::hid {

// Device-specific values from the profile (config/devices/*.toml) that no descriptor gives.
struct Layout {
    std::uint16_t vendor_id = 0x1209;
    std::uint16_t product_id = 0xFFB0;
    double position_scale = 1.0;  // position units (m or rad) per count
    double position_zero = 0.0;   // count at position 0
    double force_scale = 1.0;     // magnitude counts per N (N m)
};

namespace usage_id {
inline constexpr std::uint16_t kPageGenericDesktop = 0x01;
inline constexpr std::uint16_t kPagePid = 0x0F;
inline constexpr std::uint16_t kPageOrdinal = 0x0A;
inline constexpr std::uint32_t kX = usage(kPageGenericDesktop, 0x30);
inline constexpr std::uint32_t kY = usage(kPageGenericDesktop, 0x31);
inline constexpr std::uint32_t kSetEffectReport = usage(kPagePid, 0x21);
inline constexpr std::uint32_t kEffectBlockIndex = usage(kPagePid, 0x22);
inline constexpr std::uint32_t kEtConstantForce = usage(kPagePid, 0x26);
inline constexpr std::uint32_t kDuration = usage(kPagePid, 0x50);
inline constexpr std::uint32_t kSamplePeriod = usage(kPagePid, 0x51);
inline constexpr std::uint32_t kGain = usage(kPagePid, 0x52);
inline constexpr std::uint32_t kTriggerButton = usage(kPagePid, 0x53);
inline constexpr std::uint32_t kTriggerRepeatInterval = usage(kPagePid, 0x54);
inline constexpr std::uint32_t kAxesEnable = usage(kPagePid, 0x55);
inline constexpr std::uint32_t kDirectionEnable = usage(kPagePid, 0x56);
inline constexpr std::uint32_t kDirection = usage(kPagePid, 0x57);
inline constexpr std::uint32_t kStartDelay = usage(kPagePid, 0xA7);
inline constexpr std::uint32_t kMagnitude = usage(kPagePid, 0x70);
inline constexpr std::uint32_t kSetConstantForceReport = usage(kPagePid, 0x73);
inline constexpr std::uint32_t kEffectOperationReport = usage(kPagePid, 0x77);
inline constexpr std::uint32_t kOpEffectStart = usage(kPagePid, 0x79);
inline constexpr std::uint32_t kOpEffectStartSolo = usage(kPagePid, 0x7A);
inline constexpr std::uint32_t kOpEffectStop = usage(kPagePid, 0x7B);
inline constexpr std::uint32_t kLoopCount = usage(kPagePid, 0x7C);
inline constexpr std::uint32_t kDeviceGainReport = usage(kPagePid, 0x7D);
inline constexpr std::uint32_t kDeviceGain = usage(kPagePid, 0x7E);
inline constexpr std::uint32_t kBlockLoadReport = usage(kPagePid, 0x89);
inline constexpr std::uint32_t kBlockLoadSuccess = usage(kPagePid, 0x8C);
inline constexpr std::uint32_t kBlockFreeReport = usage(kPagePid, 0x90);
inline constexpr std::uint32_t kDeviceControlReport = usage(kPagePid, 0x95);
inline constexpr std::uint32_t kDcEnableActuators = usage(kPagePid, 0x97);
inline constexpr std::uint32_t kDcDisableActuators = usage(kPagePid, 0x98);
inline constexpr std::uint32_t kDcStopAllEffects = usage(kPagePid, 0x99);
inline constexpr std::uint32_t kDcReset = usage(kPagePid, 0x9A);
inline constexpr std::uint32_t kCreateNewEffectReport = usage(kPagePid, 0xAB);
inline constexpr std::uint32_t kByteCount = usage(kPagePid, 0xAC);
}  // namespace usage_id

enum class EffectOperation : std::uint8_t { Start, StartSolo, Stop };
enum class DeviceControl : std::uint8_t { EnableActuators, DisableActuators, StopAll, Reset };

inline constexpr std::size_t kMaxReportBytes = 64;
struct Report {
    std::array<std::uint8_t, kMaxReportBytes> bytes{};
    std::size_t size = 0;  // 0: the device has no such report
};

// Where every field hapticd uses is, from the descriptor. Field pointers point into `descriptor`;
// PidLayout is not copyable for that reason.
struct PidLayout {
    PidLayout() = default;
    PidLayout(const PidLayout&) = delete;
    PidLayout& operator=(const PidLayout&) = delete;

    ReportDescriptor descriptor;
    bool ids = false;  // reports start with their id byte
    // Input: position
    std::uint8_t input_id = 0;
    const ReportField* position = nullptr;
    std::size_t input_bytes = 0;
    // Output reports (id, length) and their fields
    std::uint8_t set_effect_id = 0, constant_id = 0, operation_id = 0, control_id = 0, gain_id = 0, free_id = 0;
    std::size_t set_effect_bytes = 0, constant_bytes = 0, operation_bytes = 0, control_bytes = 0, gain_bytes = 0,
                free_bytes = 0;
    const ReportField *se_block = nullptr, *se_type = nullptr, *se_duration = nullptr, *se_trigger_repeat = nullptr,
                      *se_sample_period = nullptr, *se_start_delay = nullptr, *se_gain = nullptr,
                      *se_trigger_button = nullptr, *se_axis_x = nullptr, *se_direction_enable = nullptr,
                      *se_direction = nullptr;
    const ReportField *cf_block = nullptr, *cf_magnitude = nullptr;
    const ReportField *op_block = nullptr, *op_operation = nullptr, *op_loop_count = nullptr;
    const ReportField* control = nullptr;
    const ReportField* device_gain = nullptr;
    const ReportField* free_block = nullptr;
    // Feature reports
    std::uint8_t create_id = 0, block_load_id = 0;
    std::size_t create_bytes = 0, block_load_bytes = 0;
    const ReportField *cr_type = nullptr, *cr_byte_count = nullptr;
    const ReportField *bl_block = nullptr, *bl_status = nullptr;
};

// Fills `layout` from a parsed descriptor; false with `error` naming the first missing report or field
// (the device is then not a HID PID constant-force device hapticd can drive) or a layout it cannot use
// (reports longer than 64 bytes, a position field wider than 32 bits).
bool build_pid_layout(const std::uint8_t* descriptor, std::size_t size, PidLayout& layout, std::string& error);

// Position of an input report (count - zero) * scale; false (nothing written) if the id or the length
// does not match. `report` is what hidraw returns (id byte first when the device uses ids).
bool decode_position(const std::uint8_t* report, std::size_t size, const PidLayout& pid, const Layout& layout,
                     double& position) noexcept;

// Set Constant Force: magnitude = round(force * force_scale) clamped to the Magnitude field's logical
// range (e.g. +-10000 or +-32767); `saturated` tells whether it was clamped. Non-finite force: 0.
Report encode_constant_force(double force, std::uint8_t block, const PidLayout& pid, const Layout& layout,
                             bool& saturated) noexcept;
// Set Effect: constant force, infinite duration (0xFFFF, hid-pidff.c PID_INFINITE), no trigger, gain at
// its logical maximum, axis X enabled, Direction Enable set, direction 90 deg.
Report encode_set_effect(std::uint8_t block, const PidLayout& pid) noexcept;
Report encode_effect_operation(std::uint8_t block, EffectOperation op, const PidLayout& pid) noexcept;
Report encode_device_control(DeviceControl control, const PidLayout& pid) noexcept;
// Device Gain as a fraction 0..1 of its logical maximum.
Report encode_device_gain(double fraction, const PidLayout& pid) noexcept;
Report encode_block_free(std::uint8_t block, const PidLayout& pid) noexcept;
// Create New Effect feature report (constant force, byte count 0).
Report encode_create_effect(const PidLayout& pid) noexcept;
// PID Block Load feature report: the block index when the status is Success; false otherwise.
bool decode_block_load(const std::uint8_t* report, std::size_t size, const PidLayout& pid,
                       std::uint8_t& block) noexcept;

// The value of the Direction field for 90 deg: a quarter of its logical range.
std::int64_t direction_90_degrees(const ReportField& direction) noexcept;

}  // namespace hapticd::hid
