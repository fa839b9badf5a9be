// SPDX-License-Identifier: Apache-2.0
// GainChecker's matrix verdicts: a force field's stiffness, the coupled loop of a scene's summed gain matrices over
// the plant set, and the ramps between two scenes (object_checks.hpp, "The sum").
#include "tuning/object_checks.hpp"

#include "common/number_text.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <hapticopt/hapticopt.hpp>

#include "tuning/tuning.hpp"

namespace hapticd {

GainChecker::FieldStiffness GainChecker::field_stiffness(const Matrix3& J) {
    const Eigen::Matrix3d m = as_eigen(J);
    const Eigen::Matrix3d s = -0.5 * (m + m.transpose());
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(s, Eigen::EigenvaluesOnly);
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m);
    FieldStiffness f;
    f.stiffness_min = es.eigenvalues().minCoeff();
    f.stiffness_max = es.eigenvalues().maxCoeff();
    f.jacobian_norm = svd.singularValues()(0);
    return f;
}

double GainChecker::largest_stiffness(const Matrix3& K) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(symmetric_part(K), Eigen::EigenvaluesOnly);
    return es.eigenvalues().maxCoeff();
}

hapticopt::MatrixGainStability GainChecker::coupled(const Matrix3& K_sum, const Matrix3& B_sum) const {
    // The gains as rendered: K_sum may carry a field's curl (antisymmetric part), kept as it is.
    const double T = plant_.period;
    const Eigen::Matrix3d Mis = as_eigen(mass_.inverse_sqrt);
    const Eigen::Matrix3d A = (T * T) * (Mis * as_eigen(K_sum) * Mis);
    const Eigen::Matrix3d Bn = T * (Mis * as_eigen(B_sum) * Mis);
    return hapticopt::general_matrix_gain_stability(normalized_for(plant_.mass), Eigen::MatrixXd(A),
                                                    Eigen::MatrixXd(Bn), estimator_);
}

namespace {

// The innermost live CommitMemo of this thread (nullptr: none); each memo keeps the one it hides and restores it.
thread_local GainChecker::CommitMemo* active_commit_memo = nullptr;

}  // namespace

GainChecker::CommitMemo::CommitMemo(const GainChecker& checker) : owner_(&checker), hidden_(active_commit_memo) {
    active_commit_memo = this;
}

GainChecker::CommitMemo::~CommitMemo() { active_commit_memo = hidden_; }

GainChecker::DirectionVerdict GainChecker::direction_over_box(double alpha, double beta, bool grid_deferred) const {
    // The memo holds the deferred verdicts (the one coupled_over_set asks for with an arm box).
    CommitMemo* memo = grid_deferred && active_commit_memo != nullptr && active_commit_memo->owner_ == this
                           ? active_commit_memo
                           : nullptr;
    const std::pair<double, double> key{alpha, beta};
    if (memo != nullptr) {
        if (const auto it = memo->verdicts_.find(key); it != memo->verdicts_.end()) {
            ++memo->hits_;
            return it->second;
        }
    }
    const double s_lo = 1.0 / scale_max_, s_hi = 1.0 / scale_min_;
    DirectionVerdict v;
    const hapticopt::ArmBoxStability box = arm_box_->over(alpha, beta, s_lo, s_hi, kAcceptArmBoxes);
    if (box.stable) {
        v.stable = v.proven = true;
    } else if (box.proven_unstable) {
        v.failing_scale = box.failing_scale;
        v.failing_delay = box.failing_delay;
        v.proven = true;
    } else {
        // Neither proven nor refuted within the subdivision limit: the grid's verdict stands, sampled. Deferred: the
        // grid's non-zero arms are judged now for this direction, each as the grid judges it (the 1 x 1 gains (alpha,
        // beta): the same tests the whole sum's matrix_over runs per common direction).
        v.stable = true;
        const Eigen::MatrixXd a1 = Eigen::MatrixXd::Constant(1, 1, alpha), b1 = Eigen::MatrixXd::Constant(1, 1, beta);
        for (std::size_t a = 1; grid_deferred && a < arm_points_.size(); ++a) {
            const hapticopt::MatrixGainScaleStability g =
                delay_tests_.empty() ? scalings_[a].matrix_over(a1, b1, s_lo, s_hi, kSampledCoupledScales)
                                     : delay_tests_[a].matrix_over(a1, b1, s_lo, s_hi, kSampledCoupledScales);
            if (!g.stable) {
                v.stable = false;
                v.failing_scale = g.failing_scale;
                v.failing_delay = g.failing_delay;
                break;
            }
        }
    }
    if (memo != nullptr) memo->verdicts_.emplace(key, v);
    return v;
}

bool GainChecker::proven_by_numerical_range(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                            const std::vector<hapticopt::GainMatrixPair>& proxies) const {
    if (!segment_box_ || proxies.size() > kMaxProvenProxies) return false;
    const double scale = A.norm() + B.norm();
    if ((A - A.transpose()).norm() > hapticopt::kMatrixGainRoundingLevel * scale ||
        (B - B.transpose()).norm() > hapticopt::kMatrixGainRoundingLevel * scale)
        return false;  // a curl: the numerical range's argument needs symmetric gains
    const Eigen::MatrixXd As = 0.5 * (A + A.transpose()), Bs = 0.5 * (B + B.transpose());
    const Eigen::MatrixXd Q = hapticopt::detail::acting_basis(As, Bs);
    if (Q.cols() == 0) return false;  // nothing acts: the caller's verdict is exact
    // The members: the sum less each subset of the proxies (every term is positive semi-definite, so each member acts
    // within the sum's acting basis). Without proxies: the sum alone.
    std::vector<hapticopt::GainMatrixPair> members;
    for (std::size_t subset = 0; subset < (std::size_t{1} << proxies.size()); ++subset) {
        Eigen::MatrixXd Am = As, Bm = Bs;
        for (std::size_t j = 0; j < proxies.size(); ++j) {
            if ((subset >> j) & 1U) continue;  // proxy j at P = I, as in the sum
            Am -= 0.5 * (proxies[j].A + proxies[j].A.transpose());
            Bm -= 0.5 * (proxies[j].B + proxies[j].B.transpose());
        }
        members.push_back(hapticopt::GainMatrixPair{Q.transpose() * Am * Q, Q.transpose() * Bm * Q});
    }
    auto verdict = [this](const hapticopt::GainSegment& g) {
        const hapticopt::ArmBoxStability box = segment_box_->segment_over(g, kAcceptArmBoxes);
        hapticopt::GainRayStability v;
        v.stable = box.stable;
        v.certified = box.stable || box.proven_unstable;  // false: neither within the box's subdivision limit
        v.failing_scale = box.failing_scale;
        return v;
    };
    return hapticopt::certify_by_numerical_range(members, 1.0 / scale_max_, 1.0 / scale_min_, kNumericalRangeDirections,
                                                 verdict, kMaxNumericalRangeDirections)
        .proven;
}

hapticopt::MatrixGainScaleStability GainChecker::coupled_over_set(const Matrix3& K_sum, const Matrix3& B_sum,
                                                                  bool prove,
                                                                  const std::vector<ProxyGains>& proxies) const {
    const double T = plant_.period;
    const Eigen::Matrix3d Mis = as_eigen(mass_.inverse_sqrt);
    const Eigen::MatrixXd A = (T * T) * (Mis * as_eigen(K_sum) * Mis);
    const Eigen::MatrixXd Bn = T * (Mis * as_eigen(B_sum) * Mis);
    // Proxies: the verdict of the configuration P = I (every arm point judged by the grid: no per-direction deferral,
    // since commuting there says nothing of the other configurations); certified by the family's numerical range.
    if (!proxies.empty()) {
        hapticopt::MatrixGainScaleStability r;
        r.stable = true;
        if (scalings_.empty()) return coupled_over_set(K_sum, B_sum, false);  // b or k > 0: never proven
        for (std::size_t a = 0; a < arm_points_.size(); ++a) {
            const hapticopt::MatrixGainScaleStability v =
                delay_tests_.empty()
                    ? scalings_[a].matrix_over(A, Bn, 1.0 / scale_max_, 1.0 / scale_min_, kSampledCoupledScales)
                    : delay_tests_[a].matrix_over(A, Bn, 1.0 / scale_max_, 1.0 / scale_min_, kSampledCoupledScales);
            r.commuting = v.commuting;
            r.spectral_radius = std::max(r.spectral_radius, v.spectral_radius);
            if (!v.stable) return v;
        }
        std::vector<hapticopt::GainMatrixPair> family;
        bool shaded = false;
        for (const ProxyGains& p : proxies) {
            shaded = shaded || p.shaded;
            family.push_back(
                hapticopt::GainMatrixPair{(T * T) * (Mis * as_eigen(p.K) * Mis), T * (Mis * as_eigen(p.B) * Mis)});
        }
        r.certified = prove && !shaded && proven_by_numerical_range(A, Bn, family);
        return r;
    }
    // The mass matrix c M gives the unit-mass gains (A, B) / c: the scales s = 1 / c. Every arm point in turn.
    hapticopt::MatrixGainScaleStability r;
    r.stable = true;
    // With the arm box, a commuting sum's grid arms other than 0 are deferred to the box, per direction
    // (direction_over_box): judged only for a direction the box neither proves nor refutes, whose verdict is then the
    // grid's. Arm 0 (the device alone; with delays the certified closed-form family) is judged first and tells whether
    // the sum commutes (the same for every arm: it depends on A, B alone).
    bool grid_deferred = false;
    for (std::size_t a = 0; a < arm_points_.size() && !grid_deferred; ++a) {
        if (!scalings_.empty()) {
            const hapticopt::MatrixGainScaleStability v =
                delay_tests_.empty()
                    ? scalings_[a].matrix_over(A, Bn, 1.0 / scale_max_, 1.0 / scale_min_, kSampledCoupledScales)
                    : delay_tests_[a].matrix_over(A, Bn, 1.0 / scale_max_, 1.0 / scale_min_, kSampledCoupledScales);
            r.commuting = v.commuting;
            r.certified = v.certified && !arm_box_;  // with an arm: certified below, per direction
            r.spectral_radius = std::max(r.spectral_radius, v.spectral_radius);
            if (!v.stable) return v;
            if (prove && a == 0 && !v.commuting && proven_by_numerical_range(A, Bn)) {
                // The proof holds for every arm, mass and delay of the set; the sampled verdict above is its anchor.
                r.certified = true;
                return r;
            }
            grid_deferred = a == 0 && arm_box_ && v.commuting;
            continue;
        }
        // b or k > 0 (one mass): the coupled verdict at each sampled mass
        const int count = scale_max_ > scale_min_ ? kSampledCoupledScales : 1;
        std::vector<double> scales{1.0};  // the nominal mass, then the set's spread
        for (int i = 0; i < count; ++i)
            scales.push_back(count == 1 ? scale_min_ : scale_min_ + (scale_max_ - scale_min_) * i / (count - 1));
        const std::vector<double> delays = sampled_delays_.empty() ? std::vector<double>{-1.0} : sampled_delays_;
        for (const double d : delays) {
            for (const double c : scales) {
                const hapticopt::MatrixGainStability v = hapticopt::general_matrix_gain_stability(
                    normalized_for(c * plant_.mass, a, d), A / c, Bn / c, estimator_);
                r.commuting = v.commuting;
                r.spectral_radius = std::max(r.spectral_radius, v.spectral_radius);
                if (!v.stable) {
                    r.stable = false;
                    r.failing_scale = 1.0 / c;
                    r.spectral_radius = v.spectral_radius;
                    r.failing_delay = d;
                    return r;
                }
            }
        }
    }
    if (arm_box_ && r.commuting) {
        // Symmetric commuting gains decouple into scalar loops along their common eigen-directions
        // (matrix_gain_stability.hpp): each direction's pair over the whole arm box, mass and delay range, certified.
        const Eigen::MatrixXd As = 0.5 * (A + A.transpose()), Bs = 0.5 * (Bn + Bn.transpose());
        const Eigen::MatrixXd Q = hapticopt::detail::acting_basis(As, Bs);
        bool unproven = false;
        if (Q.cols() > 0) {
            const Eigen::MatrixXd Ar = Q.transpose() * As * Q, Br = Q.transpose() * Bs * Q;
            for (const hapticopt::NormalizedGains& g : hapticopt::detail::common_direction_gains(Ar, Br)) {
                const DirectionVerdict d = direction_over_box(g.alpha, g.beta, grid_deferred);
                if (d.stable) {
                    unproven = unproven || !d.proven;
                    continue;
                }
                r.stable = false;
                r.failing_scale = d.failing_scale;
                r.failing_delay = d.failing_delay;
                r.certified = d.proven;
                return r;
            }
        }
        r.certified = !unproven;
    }
    return r;
}

Matrix3 GainChecker::field_stiffness_matrix(const Matrix3& J) {
    Matrix3 K{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) K[i][j] = -J[i][j];
    }
    return K;
}

bool GainChecker::field_is_stable(const Matrix3& J, const Matrix3& B_field, std::string& why,
                                  std::optional<double>& largest_stable_K) const {
    largest_stable_K.reset();
    const FieldStiffness fs = field_stiffness(J);
    const Eigen::Matrix3d j = as_eigen(J);
    const bool curl = (j - j.transpose()).norm() > hapticopt::kMatrixGainRoundingLevel * j.norm();
    if (!curl && mass_.isotropic) {
        // One mass, J symmetric: -J and B I commute; the stiffest eigen-direction with B is the verdict.
        const double B = B_field[0][0];
        if (fs.stiffness_max <= 1e-12 * (1.0 + fs.jacobian_norm) ||
            pair_is_stable(fs.stiffness_max, B, mass_.smallest())) {
            return sum_is_stable(field_stiffness_matrix(J), B_field, why);  // the margin and the free directions
        }
        const PairVerdict v = check_pair(fs.stiffness_max, B, mass_.smallest());
        why = "field: stiffness " + short_number(fs.stiffness_max) +
              " N/m (largest eigenvalue of -J) with B = " + short_number(B) +
              " N s/m is outside the stability region with " + plant_text(v) + " of " + set_text() +
              "; the largest stable K over the set at that B is " + short_number(v.largest_stable_K) + " N/m";
        largest_stable_K = v.largest_stable_K;
        return false;
    }
    std::string reason;
    if (sum_is_stable(field_stiffness_matrix(J), B_field, reason)) return true;
    std::ostringstream s;
    s.precision(6);
    s << "field: the loop it renders, stiffness -J (symmetric part with eigenvalues " << fs.stiffness_min << " .. "
      << fs.stiffness_max << " N/m";
    if (curl) s << ", and a curl (antisymmetric part) of norm " << 0.5 * (j - j.transpose()).norm() << " N/m";
    s << ") with B = " << B_field[0][0] << " N s/m, is unstable for the device mass " << mass_.describe() << ": "
      << reason;
    why = s.str();
    return false;
}

std::string GainChecker::set_text() const {
    std::ostringstream s;
    s.precision(4);
    s << "the profile's plant set: masses " << scale_min_ << " .. " << scale_max_ << " x " << mass_.describe();
    if (plant_.arm_stiffness_per_mass > 0.0 || plant_.arm_damping_per_mass > 0.0) {
        s << ", an arm with k_H / m in [0, " << plant_.arm_stiffness_per_mass << "] s^-2 and b_H / m in [0, "
          << plant_.arm_damping_per_mass << "] s^-1";
    }
    if (delay_hi_ > delay_lo_) {
        s << ", total delays " << delay_lo_ * plant_.period * 1e3 << " .. " << delay_hi_ * plant_.period * 1e3 << " ms";
    }
    return s.str();
}

bool GainChecker::sum_is_stable(const Matrix3& K_sum, const Matrix3& B_sum, std::string& why, bool prove, bool* proven,
                                const std::vector<ProxyGains>& proxies) const {
    const Eigen::Matrix3d K = symmetric_part(K_sum), B = symmetric_part(B_sum);
    if (proven != nullptr) *proven = true;  // nothing acts: the free device
    if (as_eigen(K_sum).isZero(0.0) && as_eigen(B_sum).isZero(0.0)) return true;
    // The decision: the coupled loop's verdict over the set (exact per direction when the gains commute).
    const hapticopt::MatrixGainScaleStability verdict = coupled_over_set(K_sum, B_sum, prove, proxies);
    if (proven != nullptr) *proven = verdict.stable && verdict.certified;
    if (verdict.stable && prove && !verdict.certified && !proxies.empty())
        return proxy_configurations_stable(K_sum, B_sum, proxies, why);
    if (verdict.stable) return true;
    const double failing_scale_of_mass = 1.0 / verdict.failing_scale;  // c: the mass matrix c M fails
    std::string at_delay;  // with a delay range: the total delay it fails at
    if (delay_hi_ > delay_lo_ && verdict.failing_delay >= 0.0)
        at_delay = " at the total delay " + short_number(verdict.failing_delay * plant_.period * 1e3) + " ms";
    const Eigen::Matrix3d Kr = as_eigen(K_sum);
    const double curl = 0.5 * (Kr - Kr.transpose()).norm();
    if (curl > hapticopt::kMatrixGainRoundingLevel * Kr.norm()) {
        // A curl couples the directions: no direction alone explains the verdict.
        std::ostringstream s;
        s.precision(10);
        s << "summed gains with a curl (antisymmetric part of the summed stiffness, from force fields' Jacobians, norm "
          << curl << " N/m): the coupled loop as rendered with the mass scaled by " << failing_scale_of_mass << at_delay
          << " (" << set_text() << ") has spectral radius " << verdict.spectral_radius
          << " (stable needs every root inside the unit circle: below 1 - " << hapticopt::kMatrixGainRadiusMargin
          << ", or certified by its error bound nearer)";
        why = s.str();
        return false;
    }
    // The explanation: a direction along which the pair alone is already unstable over the set, if there is one; in
    // the unit-mass coordinates y = M^1/2 x the term alpha u u^T is rendered by a plane along n ~ M^1/2 u with
    // K = alpha m_n / T^2 (m_n = 1 / (n^T M^-1 n)).
    const double T = plant_.period;
    const Eigen::Matrix3d Mis = as_eigen(mass_.inverse_sqrt), Ms = as_eigen(mass_sqrt_);
    const Eigen::Matrix3d A = (T * T) * (Mis * K * Mis), Bn = T * (Mis * B * Mis);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> ea(0.5 * (A + A.transpose())), eb(0.5 * (Bn + Bn.transpose()));
    for (const auto* solver : {&ea, &eb}) {
        for (int c = 0; c < 3; ++c) {
            const Eigen::Vector3d u = solver->eigenvectors().col(c);
            const double alpha = u.dot(A * u), beta = u.dot(Bn * u);
            if (alpha <= 1e-12 * (1.0 + A.norm()) && beta <= 1e-12 * (1.0 + Bn.norm()))
                continue;  // nothing acts along u
            const Eigen::Vector3d n = (Ms * u).normalized();
            const double m_n = mass_.along({n(0), n(1), n(2)});
            // alpha, beta are normalised with unit mass in y; along n they are the plane's with mass m_n.
            const double K_n = alpha * m_n / (T * T), B_n = beta * m_n / T;
            if (pair_is_stable(K_n, B_n, m_n)) continue;
            const PairVerdict v = check_pair(K_n, B_n, m_n);
            std::ostringstream s;
            s.precision(6);
            s << "summed gains along n = (" << n(0) << ", " << n(1) << ", " << n(2) << "): K = " << K_n
              << " N/m, B = " << B_n << " N s/m with the mass along n " << m_n << " kg (alpha = " << alpha
              << ", beta = " << beta << ") are outside the stability region with " << plant_text(v) << " of "
              << set_text() << "; the largest stable K over the set at that B is " << v.largest_stable_K << " N/m";
            why = s.str();
            return false;
        }
    }
    std::ostringstream s;
    s.precision(10);
    s << "summed gains: each direction is stable over the set on its own, but the coupled loop of K_sum and B_sum "
         "with the mass scaled by "
      << failing_scale_of_mass << at_delay << " (" << set_text() << ") has spectral radius " << verdict.spectral_radius
      << (verdict.commuting
              ? ""
              : " (the coupled check needs every root inside the unit circle: below 1 - 1e-6, or certified "
                "by its error bound nearer; docs/robust-stability.md)");
    why = s.str();
    return false;
}

bool GainChecker::proxy_configurations_stable(const Matrix3& K_sum, const Matrix3& B_sum,
                                              const std::vector<ProxyGains>& proxies, std::string& why) const {
    Eigen::Matrix3d K0 = as_eigen(K_sum), B0 = as_eigen(B_sum), K_proxies = Eigen::Matrix3d::Zero(),
                    B_proxies = Eigen::Matrix3d::Zero();
    for (const ProxyGains& p : proxies) {
        K_proxies += as_eigen(p.K);
        B_proxies += as_eigen(p.B);
    }
    K0 -= K_proxies;
    B0 -= B_proxies;
    std::vector<Eigen::Vector3d> directions;
    for (int i = 0; i < 3; ++i) directions.push_back(Eigen::Vector3d::Unit(i));
    for (int i = 0; i < 3; ++i) {
        for (int j = i + 1; j < 3; ++j) {
            directions.push_back((Eigen::Vector3d::Unit(i) + Eigen::Vector3d::Unit(j)).normalized());
            directions.push_back((Eigen::Vector3d::Unit(i) - Eigen::Vector3d::Unit(j)).normalized());
        }
    }
    for (const double y : {1.0, -1.0}) {
        for (const double z : {1.0, -1.0}) directions.push_back(Eigen::Vector3d(1.0, y, z).normalized());
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> others(0.5 * (K0 + K0.transpose()));
    for (int c = 0; c < 3; ++c) {  // unless one of the fixed ones already (a wall along an axis)
        const Eigen::Vector3d v = others.eigenvectors().col(c);
        if (std::none_of(directions.begin(), directions.end(),
                         [&](const Eigen::Vector3d& u) { return std::abs(u.dot(v)) > 1.0 - 1e-12; }))
            directions.push_back(v);
    }
    for (const Eigen::Vector3d& u : directions) {
        for (const int rank : {1, 2}) {
            const Eigen::Matrix3d P = rank == 1 ? Eigen::Matrix3d(u * u.transpose())
                                                : Eigen::Matrix3d(Eigen::Matrix3d::Identity() - u * u.transpose());
            Matrix3 K{}, B{};
            for (std::size_t r = 0; r < 3; ++r) {
                for (std::size_t c = 0; c < 3; ++c) {
                    const auto ri = static_cast<Eigen::Index>(r), ci = static_cast<Eigen::Index>(c);
                    K[r][c] = K0(ri, ci) + (P * K_proxies * P)(ri, ci);
                    B[r][c] = B0(ri, ci) + (P * B_proxies * P)(ri, ci);
                }
            }
            const hapticopt::MatrixGainScaleStability v = coupled_over_set(K, B, false);
            if (v.stable) continue;
            std::ostringstream s;
            s.precision(6);
            s << "a mesh's proxy resting on "
              << (rank == 1 ? "one face with normal" : "two faces whose edge runs along") << " (" << u(0) << ", "
              << u(1) << ", " << u(2) << ") beside the other objects: the coupled loop with the mass scaled by "
              << 1.0 / v.failing_scale;
            if (delay_hi_ > delay_lo_ && v.failing_delay >= 0.0)
                s << " at the total delay " << v.failing_delay * plant_.period * 1e3 << " ms";
            s << " (" << set_text() << ") has spectral radius " << v.spectral_radius
              << " (the proxy's contact configurations of rank 1 and 2 are judged at sampled orientations; "
                 "docs/protocol.md, section 5)";
            why = s.str();
            return false;
        }
    }
    return true;
}

bool GainChecker::ramp_is_stable(const Matrix3& K_base, const Matrix3& B_base, const Matrix3& K_in, const Matrix3& B_in,
                                 const Matrix3& K_out, const Matrix3& B_out, double step, std::string& why) const {
    if (!(step > 0.0) || step >= 1.0) return true;  // no ramp: the scene jumps from before to after
    const CommitMemo memo(*this);                   // a direction's pair met again in a later scene is judged once
    for (int j = 1;; ++j) {
        const double s = static_cast<double>(j) * step;
        if (s >= 1.0) return true;
        Matrix3 K{}, B{};
        for (std::size_t r = 0; r < 3; ++r) {
            for (std::size_t c = 0; c < 3; ++c) {
                K[r][c] = K_base[r][c] + s * s * K_in[r][c] + (1.0 - s) * (1.0 - s) * K_out[r][c];
                B[r][c] = B_base[r][c] + s * B_in[r][c] + (1.0 - s) * B_out[r][c];
            }
        }
        std::string reason;
        if (!sum_is_stable(K, B, reason, false)) {
            std::ostringstream o;
            o.precision(4);
            o << "during the ramp, " << j << " ticks after the batch (new or changed objects at weight s = " << s
              << ", the ones they replace or remove at 1 - s): " << reason;
            why = o.str();
            return false;
        }
    }
}

}  // namespace hapticd
