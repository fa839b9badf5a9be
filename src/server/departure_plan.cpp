// SPDX-License-Identifier: Apache-2.0
#include "server/departure_plan.hpp"

#include <numeric>

namespace hapticd {

namespace {

// Base (fixed + the staying objects not in `removed`) and every ramp scene of `out` fading over it.
bool departure_is_stable(const GainChecker& checker, const Matrix3& fixed_K, const Matrix3& fixed_B,
                         const std::vector<const DepartureObject*>& out, const std::vector<DepartureObject>& staying,
                         const std::vector<bool>& removed, double step, std::string& why) {
    Matrix3 K_base = fixed_K, B_base = fixed_B, K_out{}, B_out{};
    for (std::size_t i = 0; i < staying.size(); ++i) {
        if (removed[i]) continue;
        add_to(K_base, staying[i].K);
        add_to(B_base, staying[i].B);
    }
    for (const DepartureObject* o : out) {
        add_to(K_out, o->K);
        add_to(B_out, o->B);
    }
    std::string reason;
    if (!checker.sum_is_stable(K_base, B_base, reason)) {
        why = "the scene left behind is unstable: " + reason;
        return false;
    }
    if (!checker.ramp_is_stable(K_base, B_base, Matrix3{}, Matrix3{}, K_out, B_out, step, reason)) {
        why = "the ramp-out is unstable " + reason;
        return false;
    }
    return true;
}

// The next k-subset of {0 .. n-1} in lexicographic order; false after the last.
bool next_combination(std::vector<std::size_t>& c, std::size_t n) {
    const std::size_t k = c.size();
    for (std::size_t i = k; i-- > 0;) {
        if (c[i] < n - k + i) {
            ++c[i];
            for (std::size_t j = i + 1; j < k; ++j) c[j] = c[j - 1] + 1;
            return true;
        }
    }
    return false;
}

}  // namespace

DeparturePlan plan_departure(const GainChecker& checker, const Matrix3& fixed_K, const Matrix3& fixed_B,
                             const std::vector<DepartureObject>& leaving, const std::vector<DepartureObject>& staying, double step) {
    DeparturePlan plan;
    for (const DepartureObject& o : leaving) plan.out.push_back(o.slot);
    std::vector<const DepartureObject*> out;
    for (const DepartureObject& o : leaving) out.push_back(&o);
    std::vector<bool> removed(staying.size(), false);
    if (departure_is_stable(checker, fixed_K, fixed_B, out, staying, removed, step, plan.reason)) {
        plan.reason.clear();
        return plan;
    }
    const std::size_t departing = out.size();
    std::size_t tried = 0;
    std::string ignored;
    for (std::size_t k = 1; k < staying.size() && tried < kDepartureSearchBudget; ++k) {
        std::vector<std::size_t> c(k);
        std::iota(c.begin(), c.end(), std::size_t{0});
        do {
            out.resize(departing);
            std::fill(removed.begin(), removed.end(), false);
            for (const std::size_t i : c) {
                out.push_back(&staying[i]);
                removed[i] = true;
            }
            ++tried;
            if (departure_is_stable(checker, fixed_K, fixed_B, out, staying, removed, step, ignored)) {
                for (const std::size_t i : c) {
                    plan.out.push_back(staying[i].slot);
                    plan.further.push_back(staying[i].slot);
                }
                return plan;
            }
        } while (tried < kDepartureSearchBudget && next_combination(c, staying.size()));
    }
    // Every client object.
    out.resize(departing);
    for (const DepartureObject& o : staying) {
        out.push_back(&o);
        plan.out.push_back(o.slot);
        plan.further.push_back(o.slot);
    }
    std::fill(removed.begin(), removed.end(), true);
    if (!departure_is_stable(checker, fixed_K, fixed_B, out, staying, removed, step, ignored)) plan.cut = true;
    return plan;
}

}  // namespace hapticd
