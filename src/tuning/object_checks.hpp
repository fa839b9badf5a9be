// SPDX-License-Identifier: Apache-2.0
// The checks of the clients' scene objects against hapticopt's exact stability region (docs/protocol.md,
// section 5). Runs in the server thread and its workers (never in the loop).
//
// The plant: M x'' + b x' + k x = F on the device's axes, M the profile's mass matrix (one mass, one per
// axis, or a full symmetric positive-definite matrix: tuning/device_mass.hpp), b and k scalars (an
// anisotropic M only with b = k = 0: the profile refuses anything else), period T, total delay d T.
//
//  * A pair (K, B) acting with the effective mass m: alpha = K T^2 / m, beta = B T / m, is stable iff the
//    characteristic polynomial of the exact sampled-data loop has all roots inside the unit circle
//    (hapticopt::is_stable, Schur-Cohn). The largest stable K at that B: bisection in alpha on is_stable
//    between a stable alpha and alpha_max (beyond which nothing is stable), 60 halvings (2^-60 alpha_max).
//  * One object with gains K P, B P (P symmetric: n n^T for a plane or a plane spring, I - d d^T for a line
//    spring, I for a point spring): in y = M^1/2 x the plant has unit mass and the gains are K S, B S with
//    S = M^-1/2 P M^-1/2 — two multiples of one symmetric matrix, so the loop decouples along S's
//    eigenvectors into scalar loops of mass 1 / s_i (s_i > 0 its eigenvalues). The object is stable iff
//    (K, B) is stable for every such mass; for a plane the one mass is m_n = 1 / (n^T M^-1 n) (computed
//    in closed form). Cost: one 3x3 symmetric eigenproblem and <= 3 Schur-Cohn verdicts.
//  * By criterion: the optimum of hapticopt::optimal_wall for the object's mass. With b = k = 0 the
//    normalised plant (0, 0, d) does not depend on the mass, so the normalised optimum (alpha*, beta*) is
//    computed once per criterion and K = alpha* m / T^2, B = beta* m / T for any mass (exact: optimal_wall
//    scales back the same way); otherwise (one mass, b or k > 0) once per criterion for that mass. The
//    cache holds at most 7 entries either way. Objects acting with several masses (line and point springs)
//    get the optimum of the lightest: the other directions see the same (K, B) at a larger mass, and the
//    object is then checked like explicit gains.
//  * The sum: with K_sum = sum K_i P_i - sum J_f (planes and springs: K_i P_i, symmetric; a force field
//    f = J (x - x0) - B v renders the stiffness -J, its whole Jacobian: the antisymmetric part, a curl, is
//    rendered too and can destabilise the sampled, delayed loop although it stores no energy) and B_sum =
//    sum B_i P_i (symmetric), the coupled loop's verdict hapticopt::general_matrix_gain_stability for the
//    unit-mass plant of the y coordinates, A = T^2 M^-1/2 K_sum M^-1/2, B = T M^-1/2 B_sum M^-1/2: for
//    symmetric A, B the exact per-direction verdict when they commute, otherwise the eigenvalues of the
//    block companion matrix of the 3-axis loop with the delay, both stable below the spectral radius 1 - 1e-6 or,
//    nearer, with each root certified inside by its error bound, and every direction touched above the rounding
//    level judged (matrix_gain_stability.hpp). Over the
//    plant set, symmetric gains that do not commute are then proven stable for every mass, arm and delay of the
//    set by their joint numerical range (proven_by_numerical_range; docs/robust-stability.md), else sampled. The
//    header normalises with m = 1, which these are. The refusal names the first eigen-direction whose pair
//    alone is unstable, as the plane along n = M^1/2 u / |M^1/2 u| with mass m_n that renders that term
//    (K = alpha m_n / T^2, B = beta m_n / T), or the coupled spectral radius (always, with a curl).
//    Cost: 3x3 eigen-decompositions and at most 3 Schur-Cohn tests, or one ~3(d+3)-square eigenproblem.
//  * A field alone: the same coupled verdict of (-J, B I); with one mass and a symmetric J the stiffest
//    eigenvalue of -J with B gets the scalar verdict first (for the largest stable K in the refusal).
//  * The velocity estimator: every verdict above is for the loop that runs, with the profile's
//    velocity_estimator (GainCheckPlant::velocity, to_hapticopt_estimator): the backward difference takes the
//    paths as written; a low-pass or window replaces is_stable by the estimator's Schur-Cohn verdict
//    (hapticopt::EstimatorStabilityTest), alpha_max by its main stable region's
//    (hapticopt::EstimatorStabilityRegion, scanned once for the profile's mass in the constructor), the stable
//    beta interval of damping_range by that region's beta_interval (bisection on the verdict), the spectral radius
//    by the estimator loop's (hapticopt::stability with the estimator), the optimum by tune_wall with the
//    estimator, and the coupled check by general_matrix_gain_stability with the estimator. The cache needs no
//    estimator in its key: it is fixed per checker.
//  * Device limits: the profile's max_stiffness (N/m) bounds each object's stiffness along every direction
//    and the summed K_sum's largest eigenvalue of sym(K_sum) (fields: the largest eigenvalue of -sym(J);
//    the curl stores no energy and is bounded by the force limit instead).
#pragma once

#include <array>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <hapticopt/arm_box_stability.hpp>
#include <hapticopt/delay_range_stability.hpp>
#include <hapticopt/estimator_region.hpp>
#include <hapticopt/estimator_stability.hpp>
#include <hapticopt/mass_scaling_stability.hpp>
#include <hapticopt/matrix_gain_stability.hpp>
#include <hapticopt/numerical_range_certificate.hpp>
#include <hapticopt/estimator_types.hpp>

#include "tuning/device_mass.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

using Matrix3 = std::array<std::array<double, 3>, 3>;

// The same matrix as an Eigen matrix.
inline Eigen::Matrix3d as_eigen(const Matrix3& m) {
    Eigen::Matrix3d e;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) e(i, j) = m[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
    }
    return e;
}

// Its symmetric part (m + m^T) / 2.
inline Eigen::Matrix3d symmetric_part(const Matrix3& m) {
    const Eigen::Matrix3d e = as_eigen(m);
    return 0.5 * (e + e.transpose());
}

// a += b, entry by entry: gain matrices sum as the loop sums the objects' forces.
inline void add_to(Matrix3& a, const Matrix3& b) {
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) a[i][j] += b[i][j];
    }
}

// The plant the objects are checked for: TuningPlant's damping, stiffness, period and total delay, and
// the mass matrix (none: TuningPlant::mass on every axis), and the stiffness limit (none: no limit).
struct GainCheckPlant : TuningPlant {
    std::optional<DeviceMass> mass_matrix;
    std::optional<double> max_stiffness;  // N/m
    // The plant set every verdict holds for (docs/robust-stability.md): the mass matrix M scaled by c in
    // [c_min, c_max], c_min = (mass_range.first / mass) / (1 + mass_margin), c_max = (mass_range.second / mass)
    // (1 + mass_margin); without mass_range [1 / (1 + mass_margin), 1 + mass_margin]. mass_range (kg) needs one
    // mass (the profile refuses it with a mass matrix) that lies inside it; mass_margin >= 0 is relative.
    std::optional<std::pair<double, double>> mass_range;
    double mass_margin = 0.0;
    // The arm in the set (docs/robust-stability.md, "The arm"): with every mass of the set, an arm of stiffness
    // k_H with k_H / m in [0, arm_stiffness_per_mass] (s^-2) and damping b_H with b_H / m in [0,
    // arm_damping_per_mass] (s^-1), added to the plant's own k and b (on a mass matrix: k_H = that per-mass value
    // times M). 0 and 0: the device alone.
    double arm_stiffness_per_mass = 0.0;
    double arm_damping_per_mass = 0.0;
    // TuningPlant::force_noise_budget and position_resolution: criterion_gains meets the budget with that encoder
    // step (the caller gives the coarsest axis's, which bounds the step along every direction); none: no budget.
    // The total delays of the set (docs/robust-stability.md, "The delay"): [min, max] s, the profile's
    // inherent_delay_range plus the delay buffer; it holds time_delay. None: time_delay alone. Every verdict holds for
    // every delay of it, whole and fractional periods, with every mass and arm of the set.
    std::optional<std::pair<double, double>> delay_range;
};

struct PairVerdict {
    bool stable = false;
    double mass = 0.0;          // kg, the effective mass the pair was checked with (nominal: c = 1)
    double failing_mass = 0.0;  // kg, when not stable: a mass of the set (c mass) at which the pair is unstable
    // With it, the arm of the set at which it fails (N/m, N s/m; 0: the device alone).
    double failing_arm_stiffness = 0.0, failing_arm_damping = 0.0;
    double failing_delay = 0.0;  // s, the total delay of the set at which it fails (time_delay without a range)
    // false: refused because the certified arm verdict reached its subdivision limit at that plant (no proof either
    // way; hapticopt::kArmBoxMaxBoxes), not because the plant was found unstable.
    bool failing_proven = true;
    double alpha = 0.0, beta = 0.0;
    double alpha_max = 0.0;         // largest stable alpha of the plant (any beta)
    double largest_stable_K = 0.0;  // N/m at this B, stable over the whole set (0: none)
    // check_object's refusals (GainChecker::damping_range): the open interval of B (N s/m) that makes this K
    // stable with every nominal mass, and the B the daemon accepts for it alone (stable over the whole set);
    // none when no B does.
    std::optional<std::pair<double, double>> damping_stable;
    std::optional<std::pair<double, double>> damping_needed;
};

struct CriterionGains {
    double K = 0.0, B = 0.0;
};

class GainChecker {
  public:
    // Throws std::invalid_argument naming the parameter for an anisotropic mass with b or k != 0, and
    // StartupError(ErrorKind::InvalidParameter) for a velocity estimator hapticopt refuses.
    explicit GainChecker(const GainCheckPlant& plant);

    [[nodiscard]] const GainCheckPlant& plant() const noexcept { return plant_; }
    [[nodiscard]] const DeviceMass& mass() const noexcept { return mass_; }
    [[nodiscard]] std::optional<double> max_stiffness() const noexcept { return plant_.max_stiffness; }

    // The set's scale interval [c_min, c_max] of the mass (GainCheckPlant) and whether every verdict over it is
    // exact along the mass (free-mass plant: hapticopt::MassScalingTest) rather than sampled at kSampledMasses masses
    // (b or k > 0).
    [[nodiscard]] std::pair<double, double> mass_scales() const noexcept { return {scale_min_, scale_max_}; }
    [[nodiscard]] bool certified() const noexcept { return !scalings_.empty(); }
    static constexpr int kSampledMasses = 17;
    // The arm's points of the set every verdict is taken at, normalised (gamma_H, delta_H) = (k_H T^2 / m, b_H T / m):
    // the grid {0, 1/2, 1} x {0, 1/2, 1} of the box [0, arm_stiffness_per_mass T^2] x [0, arm_damping_per_mass T]
    // (one point per zero side; (0, 0) alone without an arm). Sampled, not proven, between them
    // (docs/robust-stability.md, "The arm"). A commuting sum's directions are taken at the points other than (0, 0)
    // only when the arm box neither proves nor refutes them (direction_over_box).
    [[nodiscard]] const std::vector<std::pair<double, double>>& arm_points() const noexcept { return arm_points_; }
    // "the mass 0.2 kg" or "the mass 0.2 kg with an arm k_H = 200 N/m, b_H = 0 N s/m", and " at the total delay
    // 6.5 ms" when delay_s >= 0 (for refusals).
    [[nodiscard]] static std::string plant_text(double mass, double arm_stiffness, double arm_damping,
                                                double delay_s = -1.0);
    // The same for a verdict: the delay named when the set has a delay range.
    [[nodiscard]] std::string plant_text(const PairVerdict& v) const;
    // The set's total delays [min, max] (s; time_delay twice without a range) and whether every verdict over them is
    // certified (the free-mass plant: hapticopt::DelayRangeTest; with an arm its fit is estimated, with b or k > 0
    // and for coupled sums the delays are sampled at DelayRangeTest::sampled_delays).
    [[nodiscard]] std::pair<double, double> delay_range() const noexcept {
        return {delay_lo_ * plant_.period, delay_hi_ * plant_.period};
    }
    [[nodiscard]] bool delay_certified() const noexcept { return delay_certified_; }
    // (K, B) with mass m proven stable over the whole arm box (with the set's masses and delays): the verdicts accept
    // a pair the box neither proves nor refutes within its subdivision limit when the grid's arms are stable.
    [[nodiscard]] bool pair_certified(double K, double B, double m) const;
    // Scales at which a coupled (non-commuting) sum is checked over the set, ends included, and the nominal mass
    // (each one block companion eigenproblem; docs/robust-stability.md).
    static constexpr int kSampledCoupledScales = 5;
    // "the profile's plant set: masses 0.667 .. 1.1 x 0.3 kg" (for messages).
    [[nodiscard]] std::string set_text() const;
    // The largest f in (0, 1] (less kAlphaMaxBackOff when below 1) with f (alpha, beta) (normalised with mass m) stable
    // over the set; 0: none.
    [[nodiscard]] double set_stable_factor(double m, double alpha, double beta) const;

    // Stability of one (K, B) (N/m, N s/m, finite) acting with nominal mass m (kg) for every mass c m of the set:
    // the exact verdict at the lightest and the unit-circle crossings along the mass (mass_scaling_stability.hpp).
    [[nodiscard]] bool pair_is_stable(double K, double B, double m) const;
    // The same with the mass of the set at which it fails (0 when stable).
    [[nodiscard]] bool pair_is_stable(double K, double B, double m, double& failing_mass) const;
    // The same and the largest K stable over the set at that B (61 set verdicts: for a refusal's message).
    [[nodiscard]] PairVerdict check_pair(double K, double B, double m) const;

    // The masses an object with gains (K P, B P) acts with: 1 / s_i for the eigenvalues s_i > 0 of
    // M^-1/2 P M^-1/2 (relative threshold 1e-12), ascending; for P = n n^T exactly {1 / (n^T M^-1 n)}.
    [[nodiscard]] std::vector<double> masses_of(const Matrix3& P) const;
    [[nodiscard]] double mass_along(const std::array<double, 3>& n) const noexcept { return mass_.along(n); }

    // The object (K P, B P): stable iff (K, B) is stable with each of masses_of(P). On failure the verdict
    // of the mass with the smallest largest stable K (check_pair); on success stable = true and `mass` the
    // lightest (no bisection).
    [[nodiscard]] PairVerdict check_object(double K, double B, const std::vector<double>& masses) const;

    // The dampings that make stiffness K (N/m) stable with every mass in `masses` (kg): the intersection
    // over the masses of the open interval (beta_lo, beta_hi) m / T, where (beta_lo, beta_hi) is the stable
    // beta at alpha = K T^2 / m, the two crossings of the region's boundary with that alpha
    // (hapticopt::StabilityRegion::beta_range: D-decomposition, p(e^{i theta}) = 0 solved for (alpha,
    // beta), bisection in theta to ~1e-15; with a low-pass or window estimator: the main region's interval,
    // EstimatorStabilityRegion::beta_interval, each end by bisection on the estimator's verdict to ~1e-14
    // from a stable beta of the region's scan). std::nullopt when some alpha lies outside (alpha_min,
    // alpha_max] (no B makes K stable with that mass) or the intervals do not overlap.
    // accepted: the B whose loop has a spectral radius below 1 - hapticopt::kMatrixGainRadiusMargin (the
    // margin of the summed check, which every object passes as part of the scene) instead: each end found by
    // 60 bisection steps on the loop's spectral radius (hapticopt::stability, eigenvalues of the transition
    // matrix, with the estimator's loop) between the region's end and the interval's middle; std::nullopt also when
    // the middle does not reach below that radius.
    [[nodiscard]] std::optional<std::pair<double, double>> damping_range(double K, const std::vector<double>& masses,
                                                                         bool accepted = false) const;

    // The optimum of a criterion (CE0 .. CE2+OV) for nominal mass m (kg), cached as said above, made stable over
    // the set: when the optimum (alpha*, beta*) is not, the gains f (alpha*, beta*) with the largest f < 1 that is,
    // less kAlphaMaxBackOff (the ray's stable interval through the optimum, from its unit-circle crossings; bisection
    // on the set verdict when the plant has b or k).
    // Thread-safe: the tuning runs outside the cache's lock (two threads may tune the same key once each; the first
    // result is kept). A tuning that fails (a force-noise budget the criterion cannot meet) is cached as its error and
    // thrown again (std::invalid_argument) on each call.
    CriterionGains criterion_gains(hapticopt::Criterion criterion, double m);
    // Whether criterion_gains for `criterion` answers without tuning: cached (gains or error). The key's mass is the
    // profile's: objects act with it unless b = k = 0, when the key holds for every mass.
    [[nodiscard]] bool criterion_ready(hapticopt::Criterion criterion) const;
    // criterion_gains for the profile's mass, its error kept in the cache (for a worker thread: never throws).
    void prepare_criterion(hapticopt::Criterion criterion) noexcept;

    // A field's Jacobian J: the stiffness it renders is S = -sym(J); returns the extreme eigenvalues of S
    // and the spectral norm of J (for the force bound ||F0|| + ||J|| radius).
    struct FieldStiffness {
        double stiffness_min = 0.0, stiffness_max = 0.0, jacobian_norm = 0.0;
    };
    [[nodiscard]] static FieldStiffness field_stiffness(const Matrix3& J);
    // The largest eigenvalue of sym(K) (N/m): the stiffness along the stiffest direction.
    [[nodiscard]] static double largest_stiffness(const Matrix3& K);

    // The stiffness matrix a field renders, f = J (x - x0) - B v: K = -J, the whole Jacobian with its curl.
    [[nodiscard]] static Matrix3 field_stiffness_matrix(const Matrix3& J);
    // The field alone as rendered: stiffness -J and damping B_field. On failure `why` names the reason and,
    // for a symmetric J with one mass, `largest_stable_K` the largest stable stiffness at that B.
    [[nodiscard]] bool field_is_stable(const Matrix3& J, const Matrix3& B_field, std::string& why,
                                       std::optional<double>& largest_stable_K) const;

    // A mesh's proxy in a sum (docs/protocol.md, section 5): it renders K P, B P for the projector P of its active
    // constraints (rank 1, 2 or 3, any orientation: moves are not checked); K, B are its gains at P = I as weighted in
    // the scene, and the sum passed with them holds them at P = I. With force shading the configurations are not of
    // that form (S = I + (n_s - n_f) n_f^T): `shaded`, never proven in a sum.
    struct ProxyGains {
        Matrix3 K{}, B{};
        bool shaded = false;
    };
    // Proxies a sum's proof takes (its family has 2^k members); more: accepted on the sampled verdict, not proven.
    static constexpr std::size_t kMaxProvenProxies = 4;

    // The coupled loop's verdict for physical gain matrices as rendered (K_sum may be non-symmetric: a
    // field's curl), in the unit-mass coordinates (hapticopt::general_matrix_gain_stability), nominal mass.
    [[nodiscard]] hapticopt::MatrixGainStability coupled(const Matrix3& K_sum, const Matrix3& B_sum) const;
    // The same over the set (hapticopt::MassScalingTest::matrix_over: exact for symmetric commuting gains,
    // kSampledCoupledScales scales otherwise, then proven_by_numerical_range for symmetric ones: `certified` when it
    // proves them; b or k > 0: general_matrix_gain_stability at kSampledCoupledScales masses). prove = false: the
    // sampled verdict alone for non-commuting gains (a ramp's scenes: ramp_is_stable). With `proxies` (meshes' proxies
    // in a sum with other gains) the verdict is the one of their configuration P = I (sampled or exact as above), and
    // `certified` only by the numerical range of the whole family of configurations (proven_by_numerical_range):
    // commuting at P = I says nothing of rank 1 or 2.
    [[nodiscard]] hapticopt::MatrixGainScaleStability coupled_over_set(
        const Matrix3& K_sum, const Matrix3& B_sum, bool prove = true,
        const std::vector<ProxyGains>& proxies = {}) const;
    // The summed-gain check above. On failure `why` names the direction and the pair, or the coupled radius.
    // `proven` (when given): stable and certified over the whole set (exact per direction, the arm box, or the
    // numerical range) and, with proxies, over every configuration of theirs; false: refused, or accepted on the
    // sampled verdict.
    [[nodiscard]] bool sum_is_stable(const Matrix3& K_sum, const Matrix3& B_sum, std::string& why, bool prove = true,
                                     bool* proven = nullptr, const std::vector<ProxyGains>& proxies = {}) const;

    // One common eigen-direction (alpha, beta) of a commuting sum over the whole arm box (coupled_over_set): stable
    // (proven: certified by the box; else neither proven nor refuted within kAcceptArmBoxes and the grid's verdict
    // stands), or the plant it fails at (scale s = 1 / c, total delay in periods).
    struct DirectionVerdict {
        bool stable = false;
        bool proven = false;
        double failing_scale = 0.0, failing_delay = -1.0;
    };
    // While alive, the direction verdicts of this checker's commuting sums on this thread are kept by their (alpha,
    // beta), bitwise, and a pair met again answers from here (the verdict is a function of the pair alone: the set,
    // the budget and the tests are the checker's, fixed). Scoped to one check (a commit's scenes and patterns:
    // check_engagement_patterns, ramp_is_stable); nests (the inner one answers while it lives). Not shared between
    // threads.
    class CommitMemo {
      public:
        explicit CommitMemo(const GainChecker& checker);
        ~CommitMemo();
        CommitMemo(const CommitMemo&) = delete;
        CommitMemo& operator=(const CommitMemo&) = delete;
        // Verdicts answered from the memo.
        [[nodiscard]] std::size_t hits() const noexcept { return hits_; }
        [[nodiscard]] std::size_t size() const noexcept { return verdicts_.size(); }

      private:
        friend class GainChecker;
        const GainChecker* owner_;
        CommitMemo* hidden_;
        std::map<std::pair<double, double>, DirectionVerdict> verdicts_;
        std::size_t hits_ = 0;
    };

    // The scenes a batch's ramps render (docs/protocol.md, section 5): at tick j after the batch is applied
    // the loop renders base + s_j (K_in, B_in) + (1 - s_j) (K_out, B_out) with s_j = j step (step = T /
    // ramp_time, the loop's ramp increment), from the scene before the batch (s = 0) to the scene after it
    // (s = 1). Sums of stable scenes need not be stable (the stable set of gain matrices is not convex when
    // the directions do not commute), so every intermediate s_j, 0 < s_j < 1, is checked with sum_is_stable:
    // at most 1 / step - 1 verdicts. On failure `why` says at which s and why. Non-commuting ramp scenes keep the
    // sampled verdict (prove = false): each is rendered for one tick, a frozen scene's verdict does not prove the
    // time-varying ramp anyway, and the proof would cost up to m + 2 box verdicts per scene, most of them failing on
    // the ramp's soft early directions.
    [[nodiscard]] bool ramp_is_stable(const Matrix3& K_base, const Matrix3& B_base, const Matrix3& K_in,
                                      const Matrix3& B_in, const Matrix3& K_out, const Matrix3& B_out, double step,
                                      std::string& why) const;

    // The loop's velocity estimator every decision above uses (to_hapticopt_estimator of plant().velocity).
    [[nodiscard]] const hapticopt::VelocityEstimator& estimator() const noexcept { return estimator_; }

  private:
    // The normalised plant with mass m and the arm point `arm` (index into arm_points_; 0: none).
    // delay: periods (< 0: the nominal time_delay).
    [[nodiscard]] hapticopt::NormalizedPlant normalized_for(double m, std::size_t arm = 0, double delay = -1.0) const;
    [[nodiscard]] double alpha_max_for(double m) const;
    // The scalar verdict with the estimator (hapticopt::is_stable for the backward difference).
    [[nodiscard]] bool stable(const hapticopt::NormalizedPlant& np, double alpha, double beta) const;
    // The scalar verdict over the set for gains normalised with mass m: true, or false and the failing mass (and
    // the failing arm point's index).
    [[nodiscard]] bool stable_over_set(double m, double alpha, double beta, double& failing_mass) const;
    // The plant a verdict over the set fails at: its mass (kg), arm (gamma_H, delta_H normalised with that mass), total
    // delay (s), and whether it was found unstable (false: the certified verdict's subdivision limit).
    struct SetFailure {
        double mass = 0.0;
        std::pair<double, double> arm{0.0, 0.0};
        double delay = 0.0;
        bool proven = true;
    };
    // certify: with an arm, the whole arm box too (hapticopt::ArmBoxTest, subdivided into at most max_boxes
    // sub-boxes); false: the grid's arms alone (exact along the mass at each: a bisection's inner steps, whose end is
    // then certified). The searches for a certified end (largest_stable_K, damping_needed, a criterion's derating)
    // certify with kSearchArmBoxes: near the boundary a verdict subdivides to its limit (~0.5 s at 4096 on the sim
    // profile), and "not proven" only moves the end inwards.
    // An object's or a scene's verdict subdivides to kAcceptArmBoxes: beyond, neither proven nor refuted, the grid's
    // verdict stands (sampled) — a commit judges up to ~30 ramp scenes, and near the boundary a verdict can subdivide
    // to any limit.
    static constexpr int kSearchArmBoxes = 64;
    static constexpr int kAcceptArmBoxes = 256;
    [[nodiscard]] bool stable_over_set(double m, double alpha, double beta, SetFailure& failure, bool certify = true,
                                       int max_boxes = kAcceptArmBoxes) const;
    // f if f (alpha, beta) is stable over the whole set (certified), else the largest stable f' < f found by 30
    // bisection steps on the certified verdict, kAlphaMaxBackOff inside when that is stable too (0: none).
    [[nodiscard]] double certified_factor_below(double m, double alpha, double beta, double f) const;
    // A commuting sum's direction (alpha, beta) over the arm box (arm_box_ set), the live CommitMemo first.
    // grid_deferred: the grid's arms other than 0 were not judged (coupled_over_set); a direction the box neither
    // proves nor refutes is then judged at each of them as the grid judges it (exact along the mass, and over the
    // delays by the estimated DelayRangeTest), so it is accepted only when the grid's full verdict holds, as without
    // the deferral. A direction the box proves stable needs no more: the box is certified over every arm, mass and
    // delay of the set, the grid's among them (a grid test could only refuse it wrongly: the estimated fit's residual).
    // A direction it refutes is refused with the box's plant. Cost saved per proven direction: 8 exact crossing
    // computations along the mass (~0.3 ms each on the Falcon's window 15) and, with delays, 8 estimated DelayRangeTest
    // verdicts.
    [[nodiscard]] DirectionVerdict direction_over_box(double alpha, double beta, bool grid_deferred) const;
    // Summed gains A, B (normalised for the reference mass matrix, symmetric to the rounding level, not commuting)
    // proven stable over the whole set by their joint numerical range (hapticopt::certify_by_numerical_range, every
    // edge judged by segment_box_ over the arm box, masses and delays, kAcceptArmBoxes sub-boxes each), with
    // kNumericalRangeDirections support lines, refined where an edge fails outside the range's hull, up to
    // kMaxNumericalRangeDirections. The anchor (the coupled loop stable at one plant) is the caller's. false: not
    // proven (a curl, b or k > 0, or an edge not proven stable). With `proxies` (normalised as A, B, held in them at
    // P = I): the family of every configuration of theirs (numerical_range_certificate.hpp, "Families"), its members
    // A, B less each subset of the proxies; false for a shaded proxy or more than kMaxProvenProxies.
    [[nodiscard]] bool proven_by_numerical_range(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                                 const std::vector<hapticopt::GainMatrixPair>& proxies = {}) const;
    // The sampled configurations of proxies in a sum the family's proof did not prove (sum_is_stable, prove): every
    // proxy with the projector P = u u^T (rank 1) and I - u u^T (rank 2) for u along the 3 axes, the 6 face and 4 body
    // diagonals and the eigenvectors of the other terms' stiffness, each over the set as coupled_over_set judges P = I.
    // false with `why` naming the first unstable configuration. Sampled: a configuration between them is not judged.
    [[nodiscard]] bool proxy_configurations_stable(const Matrix3& K_sum, const Matrix3& B_sum,
                                                   const std::vector<ProxyGains>& proxies, std::string& why) const;
    static constexpr int kNumericalRangeDirections = 16;
    static constexpr int kMaxNumericalRangeDirections = 256;
    // The estimator's main stable region for mass m (the profile's, built once, or a new one); non-backward only.
    [[nodiscard]] std::shared_ptr<const hapticopt::EstimatorStabilityRegion> estimator_region_for(double m) const;

    GainCheckPlant plant_;
    hapticopt::VelocityEstimator estimator_;
    std::shared_ptr<const hapticopt::EstimatorStabilityRegion> region_;  // non-backward: for the profile's mass
    DeviceMass mass_;
    MassMatrix mass_sqrt_{};                    // M^1/2
    bool free_mass_plant_ = false;              // b = k = 0: the normalised plant does not depend on the mass
    double alpha_max_ = 0.0;                    // for the profile's mass (any mass when free_mass_plant_)
    double scale_min_ = 1.0, scale_max_ = 1.0;  // the set's masses: c M, c in [scale_min_, scale_max_]
    std::vector<std::pair<double, double>> arm_points_{{0.0, 0.0}};  // normalised (gamma_H, delta_H), (0, 0) first
    std::vector<hapticopt::MassScalingTest>
        scalings_;                            // free_mass_plant_: the exact test along the mass, per arm point
    double delay_lo_ = 0.0, delay_hi_ = 0.0;  // periods: the set's total delays
    bool delay_certified_ = true;
    std::vector<double> sampled_delays_;  // periods: b or k > 0 (DelayRangeTest::sampled_delays), else empty
    std::vector<hapticopt::DelayRangeTest> delay_tests_;  // free_mass_plant_ with a delay range: per arm point
    // free_mass_plant_ with an arm: the certified verdict over the whole arm box, every mass and delay of the set.
    std::optional<hapticopt::ArmBoxTest> arm_box_;
    // free_mass_plant_: the same box (the arm's or none) for gain segments (proven_by_numerical_range).
    std::optional<hapticopt::ArmBoxTest> segment_box_;
    // The criterion's gains, or the error its tuning threw.
    struct CachedCriterion {
        CriterionGains gains;
        std::string error;  // empty: gains hold
    };
    [[nodiscard]] std::pair<hapticopt::Criterion, double> cache_key(hapticopt::Criterion criterion, double m) const {
        return {criterion, free_mass_plant_ ? 0.0 : m};
    }
    CachedCriterion tune_criterion(hapticopt::Criterion criterion, double m);
    mutable std::mutex cache_mutex_;
    std::map<std::pair<hapticopt::Criterion, double>, CachedCriterion>
        cache_;  // key mass: 0 when free_mass_plant_ (normalised)
};

}  // namespace hapticd
