// SPDX-License-Identifier: Apache-2.0
#include "server/departure_plan.hpp"

#include <numeric>

namespace hapticd {

namespace {

// Base (fixed + the staying objects not in `removed`) and every ramp scene of `out` fading over it, each with
// every engagement pattern; `checks` counts the verdicts spent.
bool departure_is_stable(const GainChecker& checker, const std::vector<SceneTerm>& fixed,
                         const std::vector<const DepartureObject*>& out, const std::vector<DepartureObject>& staying,
                         const std::vector<bool>& removed, double step, std::string& why, std::size_t& checks,
                         const std::atomic<bool>* cancel, bool& cancelled) {
    std::vector<SceneTerm> terms = fixed;
    for (std::size_t i = 0; i < staying.size(); ++i) {
        if (removed[i]) continue;
        terms.push_back(staying[i].term);
        terms.back().role = SceneTerm::Role::Base;
    }
    for (const DepartureObject* o : out) {
        terms.push_back(o->term);
        terms.back().role = SceneTerm::Role::Out;
    }
    // No pattern limit: the scene was accepted with its patterns; its departure removes terms, never adds any.
    const EngagementCheck verdict = check_engagement_patterns(checker, terms, step, PatternLimit::None, cancel);
    checks += verdict.checks;
    cancelled = cancelled || verdict.cancelled;
    if (verdict.stable) return true;
    why = "the scene left behind or its ramp-out is unstable: " + verdict.why;
    return false;
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

DeparturePlan plan_departure(const GainChecker& checker, const std::vector<SceneTerm>& fixed,
                             const std::vector<DepartureObject>& leaving, const std::vector<DepartureObject>& staying,
                             double step, const std::atomic<bool>* cancel) {
    DeparturePlan plan;
    for (const DepartureObject& o : leaving) plan.out.push_back(o.slot);
    std::vector<const DepartureObject*> out;
    for (const DepartureObject& o : leaving) out.push_back(&o);
    std::vector<bool> removed(staying.size(), false);
    std::size_t checks = 0;
    if (departure_is_stable(checker, fixed, out, staying, removed, step, plan.reason, checks, cancel, plan.cancelled)) {
        plan.reason.clear();
        return plan;
    }
    if (plan.cancelled) return plan;
    const std::size_t departing = out.size();
    std::size_t tried = 0;
    checks = 0;
    std::string ignored;
    auto within_budget = [&] {
        return !plan.cancelled && tried < kDepartureSearchBudget && checks < kDepartureCheckBudget;
    };
    for (std::size_t k = 1; k < staying.size() && within_budget(); ++k) {
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
            if (departure_is_stable(checker, fixed, out, staying, removed, step, ignored, checks, cancel,
                                    plan.cancelled)) {
                for (const std::size_t i : c) {
                    plan.out.push_back(staying[i].slot);
                    plan.further.push_back(staying[i].slot);
                }
                return plan;
            }
        } while (within_budget() && next_combination(c, staying.size()));
    }
    if (plan.cancelled) return plan;
    // Every client object.
    out.resize(departing);
    for (const DepartureObject& o : staying) {
        out.push_back(&o);
        plan.out.push_back(o.slot);
        plan.further.push_back(o.slot);
    }
    std::fill(removed.begin(), removed.end(), true);
    if (!departure_is_stable(checker, fixed, out, staying, removed, step, ignored, checks, cancel, plan.cancelled))
        plan.cut = true;
    return plan;
}

}  // namespace hapticd
