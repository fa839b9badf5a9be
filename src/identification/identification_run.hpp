// SPDX-License-Identifier: Apache-2.0
// Identification on a device at start-up (before rendering): the excitation, the tuning from the
// estimates with propagated uncertainty, and the identification file (save, reuse, compare).
//
// Excitation (excitation_signal): blocks of force +A for L periods, -A for 2L, +A for L, with L drawn
// from {2, 4, 8, 16, 32, 64} ms and a random sign (xorshift64*, fixed seed), then a settle tail of zero
// force. Each block has zero net impulse and zero first moment, so a pure mass (the worst case: no
// spring, no damping to hold it) starts and ends every block at rest at its start position, and its peak
// excursion within a block is A (L T)^2 / m. A is chosen per L as
//     A_L = min(0.8 force_limit, excursion_fraction * position_limit * (design_mass / mass_margin) / (L T)^2),
// so the designed peak is at most excursion_fraction (0.3) of the position limit for any mass down to
// design_mass / mass_margin (half the profile mass); the delay only shifts the response. A spring whose
// period equals a block's (4 L T) rings up to 16/pi^2 = 1.62 times that within one block (the square
// wave's fundamental at resonance), so about 0.49 of the limit: the guard (0.8) keeps a margin. |u| <=
// force_limit always (the force limit itself is clamped to the device's max_force).
// At run time a block's sign stays random while the device is near rest; when the position predicted L
// periods ahead (from y and a 5-period backward-difference velocity) is more than 5 % of the limit away
// from the start, the block's first push opposes it (blocks then remove energy from a spring's ringing
// instead of pumping it). The force written is that plus a weak centering PD, -Kc (y_j - y_start) - Bc (y_j -
// y_{j-5})/(5T), Kc = m_d (2 pi f_c)^2, Bc = 2 0.7 m_d 2 pi f_c, f_c = 1 Hz (m_d the design mass), clamped to the 0.2
// force_limit the blocks leave free (so the sum is never clipped and each block keeps zero impulse): it keeps a
// spring's resonance or a drift from accumulating over blocks. The estimator uses the force actually written, so the
// feedback does not bias it (output error with known input). At run time (run_excitation) a guard aborts when |y -
// y_start| > guard_fraction (0.8) * position_limit or on any device error, non-finite position or stop request: zero
// force is written on that tick and on every path out. The excitation is not in the real-time loop (rendering has not
// started): it paces itself with clock_nanosleep to absolute deadlines (or runs back to back for lockstep simulations).
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "devices/device.hpp"
#include "identification/identification.hpp"
#include "config/options.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

struct ExcitationSettings {
    std::size_t axis = 0;
    double period = 1e-3;               // s
    double duration = 2.0;              // s of excitation blocks
    double settle = 0.3;                // s of zero force at the end
    double force_limit = 1.0;           // N (N m), |u| <= force_limit
    double position_limit = 0.005;      // m (rad), allowed |x - x_start|
    double design_mass = 0.3;           // kg (kg m^2): the profile's mass
    double mass_margin = 2.0;           // amplitudes designed for design_mass / mass_margin
    double excursion_fraction = 0.3;    // designed pure-mass peak / position_limit
    double guard_fraction = 0.8;        // abort above this fraction of position_limit
    double centering_hz = 1.0;          // weak PD centering (for design_mass): natural frequency, Hz (0: off)
    double block_force_fraction = 0.8;  // of force_limit for the blocks; the rest is the centering's
    std::uint64_t seed = 1;
    bool paced = true;  // sleep to absolute deadlines; false: back to back (simulation)
};

// The open-loop force sequence u_j with the random signs (the settle tail included; the last sample is
// zero). run_excitation adds the centering and may flip a block's sign (see above).
std::vector<double> excitation_signal(const ExcitationSettings& settings);

struct ExcitationRecord {
    IdentificationData data;  // what was written and read (up to the abort)
    bool completed = false;
    std::string abort_reason;  // when not completed
    DeviceStatus status = DeviceStatus::Ok;
    bool guard_tripped = false;
    bool stopped = false;  // SIGINT/SIGTERM
    double max_abs_force = 0.0;
    double max_excursion = 0.0;  // max |y - y_start|
    double start_position = 0.0;
};

// Runs the excitation on an open, homed device. Writes zero force on every path out.
ExcitationRecord run_excitation(Device& device, const ExcitationSettings& settings);

// Optimal gains for the identified plant (b, k clamped to >= 0; total delay = d T + extra_delay) with
// standard errors of K and B by the delta method: gradient by forward differences over half a standard
// error of (m, b, k, d), var = g^T Cov g with the 4x4 covariance of the fit.
struct IdentifiedTuning {
    TuningPlant plant;
    TuningResult tuning;
    double K_stderr = 0.0;
    double B_stderr = 0.0;
};
// `velocity`: the loop's velocity estimator, which the tuning analyses with (TuningPlant::velocity).
IdentifiedTuning tune_identified(hapticopt::Criterion criterion, const IdentificationResult& result, double period,
                                 double extra_delay, const VelocityEstimatorSpec& velocity = {});

// The identification file (JSON).
nlohmann::json identification_to_json(const IdentificationResult& result, const std::string& device);
// Throws std::runtime_error naming the missing or invalid key.
IdentificationResult identification_from_json(const nlohmann::json& j, std::string& device);

// Differences between two identifications beyond their uncertainty: |a - b| > max(n_sigma sqrt(sa^2 + sb^2),
// floor) with floors 1 % of the mass, 5 % of the damping or 0.01 m/T, 1e-3 m/T^2 for the stiffness and
// 0.1 period for the delay (the accuracy the tests verify). One message per changed quantity.
std::vector<std::string> compare_identifications(const IdentificationResult& before, const IdentificationResult& now,
                                                 double n_sigma = 3.0);

// What `--identify` / `--identification-file` did at start-up.
struct IdentificationStage {
    bool excited = false;  // the excitation ran now
    bool reused = false;   // results read from the file
    std::string file;      // identification file ("" : none)
    bool saved = false;
    IdentificationResult result;
    ExcitationSettings excitation;     // when excited
    ExcitationRecord record;           // when excited (data cleared)
    std::vector<std::string> changes;  // vs the previous file
};

// Runs or reuses the identification as the options ask; nullopt when neither was asked (or the file to
// reuse does not exist: a warning on err). Throws StartupError: 3 unreadable file, 6 device error or
// failed identification, 7 position guard, 0 stopped by a signal.
std::optional<IdentificationStage> run_identification_stage(const Options& options, const DeviceProfile& profile,
                                                            double period, std::ostream& out, std::ostream& err);

// One line per quantity, configured vs identified.
std::string identification_text(const IdentificationStage& stage, const DeviceProfile& profile, double period);
// The summary JSON's "identified" object.
nlohmann::json identification_summary_json(const IdentificationStage& stage, const DeviceProfile& profile,
                                           double period, const TuningResult* configured_tuning,
                                           const IdentifiedTuning* identified_tuning);

}  // namespace hapticd
