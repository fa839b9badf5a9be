// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <hapticopt/parameters.hpp>

namespace hapticopt {
namespace {

TEST(Parameters, NormalizationRoundTripsThroughTableOne) {
    const PhysicalPlant p{0.3, 2.0, 150.0, 0.001, 0.0025};
    const NormalizedPlant n = normalize(p);
    EXPECT_DOUBLE_EQ(n.gamma, 150.0 * 1e-6 / 0.3);
    EXPECT_DOUBLE_EQ(n.delta, 2.0 * 1e-3 / 0.3);
    EXPECT_DOUBLE_EQ(n.delay, 2.5);
    const PhysicalPlant back = to_physical(n, p.mass, p.period);
    EXPECT_NEAR(back.stiffness, p.stiffness, 1e-12 * p.stiffness);
    EXPECT_NEAR(back.damping, p.damping, 1e-12 * p.damping);
    EXPECT_NEAR(back.time_delay, p.time_delay, 1e-15);
    const WallGains g{20000.0, 40.0};
    const NormalizedGains ng = normalize(g, 0.3, 0.001);
    EXPECT_DOUBLE_EQ(ng.alpha, 20000.0 * 1e-6 / 0.3);
    EXPECT_DOUBLE_EQ(ng.beta, 40.0 * 1e-3 / 0.3);
    const WallGains gb = to_physical(ng, 0.3, 0.001);
    EXPECT_NEAR(gb.stiffness, g.stiffness, 1e-9);
    EXPECT_NEAR(gb.damping, g.damping, 1e-12);
}

void expect_invalid(const PhysicalPlant& p, const std::string& parameter, const std::string& range) {
    try {
        normalize(p);
        FAIL() << "no exception for " << parameter;
    } catch (const InvalidParameter& e) {
        const std::string what = e.what();
        EXPECT_EQ(e.parameter(), parameter);
        EXPECT_NE(what.find("hapticopt::normalize"), std::string::npos) << what;
        EXPECT_NE(what.find(parameter + " = "), std::string::npos) << what;
        EXPECT_NE(what.find(range), std::string::npos) << what;
    }
}

TEST(Parameters, InvalidPhysicalInputNamesFunctionParameterValueAndRange) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    expect_invalid({0.0, 0, 0, 1e-3, 0}, "mass", "> 0");
    expect_invalid({-1.0, 0, 0, 1e-3, 0}, "mass", "> 0");
    expect_invalid({nan, 0, 0, 1e-3, 0}, "mass", "> 0");
    expect_invalid({1.0, -0.1, 0, 1e-3, 0}, "damping", ">= 0");
    expect_invalid({1.0, 0, -5, 1e-3, 0}, "stiffness", ">= 0");
    expect_invalid({1.0, 0, 0, 0.0, 0}, "period", "> 0");
    expect_invalid({1.0, 0, 0, inf, 0}, "period", "> 0");
    expect_invalid({1.0, 0, 0, 1e-3, -1e-3}, "time_delay", ">= 0");
    expect_invalid({1.0, 0, inf, 1e-3, 0}, "stiffness", ">= 0");
    try {
        normalize(PhysicalPlant{-2.5, 0, 0, 1e-3, 0});
    } catch (const InvalidParameter& e) {
        EXPECT_DOUBLE_EQ(e.value(), -2.5);
        EXPECT_NE(std::string(e.what()).find("-2.5"), std::string::npos);
    }
}

TEST(Parameters, InvalidNormalizedInputIsRejected) {
    EXPECT_THROW(validate(NormalizedPlant{-1e-9, 0, 0}), InvalidParameter);
    EXPECT_THROW(validate(NormalizedPlant{0, -1e-9, 0}), InvalidParameter);
    EXPECT_THROW(validate(NormalizedPlant{0, 0, -0.5}), InvalidParameter);
    EXPECT_THROW(validate(NormalizedGains{std::nan(""), 0}), InvalidParameter);
    EXPECT_THROW(validate(NormalizedGains{0, HUGE_VAL}), InvalidParameter);
    EXPECT_NO_THROW(validate(NormalizedGains{-0.5, -0.5}));
}

}  // namespace
}  // namespace hapticopt
