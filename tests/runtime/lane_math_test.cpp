// SPDX-License-Identifier: Apache-2.0
// lane_exp, lane_exp_no_overflow, lane_log and lane_atan2 against libm over their documented
// ranges, in ulp.
#include "imm/math/lane_math.hpp"

// 64-byte vectors by value in the test (lane_math.hpp says why that is harmless).
#pragma GCC diagnostic ignored "-Wpsabi"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace imm {
namespace {

// The distance in units in the last place between two finite doubles of one sign.
std::int64_t ulps(double a, double b) {
  const auto ia = std::bit_cast<std::int64_t>(a), ib = std::bit_cast<std::int64_t>(b);
  return ia > ib ? ia - ib : ib - ia;
}

TEST(LaneMath, ExpIsWithinTwoUlpOfLibmOverItsRange) {
  std::mt19937_64 engine(7);
  std::uniform_real_distribution<double> wide(-708.0, 709.0), near(-1.0, 1.0);
  std::int64_t worst = 0;
  for (int i = 0; i < 200000; ++i) {
    const double x = i % 2 == 0 ? wide(engine) : near(engine);
    const double expected = std::exp(x);
    const double got = lane_exp(x);
    ASSERT_LE(ulps(got, expected), 2) << "x = " << x;
    worst = std::max(worst, ulps(got, expected));
  }
  for (const double x : {0.0, -0.0, 1.0, -1.0, 0.5 * std::log(2.0), -708.0, 709.0, 1e-300}) {
    EXPECT_LE(ulps(lane_exp(x), std::exp(x)), 2) << x;
  }
  EXPECT_EQ(lane_exp(0.0), 1.0);
  EXPECT_EQ(lane_exp(-709.0), 0.0);  // libm's subnormal results are flushed
  EXPECT_EQ(lane_exp(-1e300), 0.0);
  EXPECT_EQ(lane_exp(-std::numeric_limits<double>::infinity()), 0.0);
  EXPECT_EQ(lane_exp(710.0), std::numeric_limits<double>::infinity());
  EXPECT_EQ(lane_exp(std::numeric_limits<double>::infinity()),
            std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(lane_exp(std::numeric_limits<double>::quiet_NaN())));
  RecordProperty("worst_ulp", static_cast<int>(worst));
}

TEST(LaneMath, LogIsWithinTwoUlpOfLibmForEveryPositiveDouble) {
  std::mt19937_64 engine(11);
  std::uniform_real_distribution<double> mantissa(1.0, 2.0);
  std::uniform_int_distribution<int> exponent(-1074, 1023);
  std::uniform_real_distribution<double> near_one(0.5, 2.0);
  for (int i = 0; i < 200000; ++i) {
    // Every binade (subnormals included) equally, and the cancellation region around 1.
    const double x = i % 2 == 0 ? std::ldexp(mantissa(engine), exponent(engine)) : near_one(engine);
    if (!(x > 0.0)) continue;
    const double expected = std::log(x);
    ASSERT_LE(ulps(lane_log(x), expected), 2) << "x = " << x;
  }
  for (const double x :
       {1.0, 2.0, 0.5, std::sqrt(2.0), std::sqrt(0.5), 1.0 + 1e-15, 1.0 - 1e-16,
        std::numeric_limits<double>::min(), std::numeric_limits<double>::denorm_min(),
        std::numeric_limits<double>::max()}) {
    EXPECT_LE(ulps(lane_log(x), std::log(x)), 2) << x;
  }
  EXPECT_EQ(lane_log(1.0), 0.0);
  EXPECT_EQ(lane_log(0.0), -std::numeric_limits<double>::infinity());
  EXPECT_EQ(lane_log(std::numeric_limits<double>::infinity()),
            std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(lane_log(-1.0)));
  EXPECT_TRUE(std::isnan(lane_log(std::numeric_limits<double>::quiet_NaN())));
}

TEST(LaneMath, Atan2IsWithinTwoUlpOfLibmInEveryQuadrant) {
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-40, 40);
  std::int64_t worst = 0;
  for (int i = 0; i < 2000000; ++i) {
    // Both coordinates over 80 binades, and near the axes and diagonals.
    double y = std::ldexp(unit(rng), exponent(rng)), x = std::ldexp(unit(rng), exponent(rng));
    if (i % 7 == 1) x = y * (1.0 + 1e-9 * unit(rng));
    if (i % 7 == 2) x = -y * (1.0 + 1e-9 * unit(rng));
    if (i % 11 == 3) y = 1e-300 * unit(rng);
    const double got = lane_atan2(y, x), expected = std::atan2(y, x);
    ASSERT_LE(ulps(got, expected), 2) << "atan2(" << y << ", " << x << ")";
    worst = std::max(worst, ulps(got, expected));
  }
  EXPECT_LE(worst, 2);
  // The axes and the zeros, signs included, as libm.
  for (const double y : {0.0, -0.0, 1.0, -1.0}) {
    for (const double x : {0.0, -0.0, 1.0, -1.0}) {
      if (x != 0.0 && y != 0.0) continue;  // the diagonals: within 2 ulp above
      EXPECT_EQ(std::bit_cast<std::uint64_t>(lane_atan2(y, x)),
                std::bit_cast<std::uint64_t>(std::atan2(y, x)))
          << y << ", " << x;
    }
  }
  EXPECT_TRUE(std::isnan(lane_atan2(std::nan(""), 1.0)));
  EXPECT_TRUE(std::isnan(lane_atan2(1.0, std::nan(""))));
}

// lane_exp_no_overflow over its domain (x ≤ 709 and NaN): lane_exp's bits, for a double and for
// every element of a pack, and so within 2 ulp of libm's exp from −708 on.
TEST(LaneMath, ExpWithoutTheOverflowCheckIsLaneExpToTheBitUpTo709) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const auto same = [](double a, double b) {
    return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
  };
  std::vector<double> values = {0.0,
                                -0.0,
                                -5e-324,
                                -1e-300,
                                -0.5 * std::log(2.0),
                                -708.0,
                                std::nextafter(-708.0, -kInf),
                                std::nextafter(-708.0, 0.0),
                                -709.0,
                                -745.2,
                                -1e300,
                                -kInf,
                                1e-300,
                                1.0,
                                700.0,
                                std::nextafter(709.0, 0.0),
                                709.0,
                                std::numeric_limits<double>::quiet_NaN()};
  std::mt19937_64 engine(11);
  std::uniform_real_distribution<double> wide(-760.0, 709.0), near(-1.0, 1.0);
  std::uniform_real_distribution<double> magnitude(-300.0, 3.0);
  for (int i = 0; i < 100000; ++i) {
    values.push_back(i % 3 == 0   ? wide(engine)
                     : i % 3 == 1 ? near(engine)
                                  : -std::pow(10.0, magnitude(engine)));
  }
  for (const double x : values) {
    const double got = lane_exp_no_overflow(x);
    ASSERT_TRUE(same(got, lane_exp(x))) << "x = " << x;
    if (x >= -708.0 && x <= 709.0) {
      ASSERT_LE(ulps(got, std::exp(x)), 2) << "x = " << x;
    }
  }
  EXPECT_EQ(lane_exp_no_overflow(0.0), 1.0);
  EXPECT_EQ(lane_exp_no_overflow(-710.0), 0.0);
  EXPECT_EQ(lane_exp_no_overflow(-kInf), 0.0);
  EXPECT_TRUE(std::isnan(lane_exp_no_overflow(std::numeric_limits<double>::quiet_NaN())));
  for (std::size_t first = 0; first + kLanePackWidth <= values.size(); first += kLanePackWidth) {
    LanePack x;
    for (int l = 0; l < kLanePackWidth; ++l) x[l] = values[first + static_cast<std::size_t>(l)];
    const LanePack e = lane_exp_no_overflow(x);
    for (int l = 0; l < kLanePackWidth; ++l) {
      ASSERT_TRUE(same(e[l], lane_exp(x[l]))) << "exp(" << x[l] << ")";
    }
  }
}

TEST(LaneMath, PickSelectsEitherValueBitForBit) {
  EXPECT_EQ(std::bit_cast<std::uint64_t>(pick(true, -0.0, 1.0)),
            std::bit_cast<std::uint64_t>(-0.0));
  EXPECT_EQ(pick(false, -0.0, 1.0), 1.0);
  EXPECT_TRUE(std::isnan(pick(true, std::numeric_limits<double>::quiet_NaN(), 1.0)));
}

// A LanePack's elements get the double's bits, the special values included, and pick selects
// element by element.
TEST(LaneMath, PackElementsEqualTheDoubleFunctionToTheBit) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::vector<double> values = {0.0,    -0.0,   1.0,   -1.0,
                                1e-310, 5e-324, 709.5, -709.5,
                                -745,   kInf,   -kInf, std::numeric_limits<double>::quiet_NaN()};
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> exponent(-300.0, 300.0);
  std::uniform_real_distribution<double> argument(-720.0, 720.0);
  for (int i = 0; i < 4000; ++i) {
    values.push_back(std::pow(10.0, exponent(rng)));
    values.push_back(argument(rng));
  }
  const auto same = [](double a, double b) {
    return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
  };
  for (std::size_t first = 0; first + kLanePackWidth <= values.size(); first += kLanePackWidth) {
    LanePack x;
    for (int l = 0; l < kLanePackWidth; ++l) x[l] = values[first + static_cast<std::size_t>(l)];
    const LanePack e = lane_exp(x), g = lane_log(x);
    const LanePack chosen = pick(x > 1.0, x, -x);
    for (int l = 0; l < kLanePackWidth; ++l) {
      const double v = x[l];
      ASSERT_TRUE(same(e[l], lane_exp(v))) << "exp(" << v << ")";
      ASSERT_TRUE(same(g[l], lane_log(v))) << "log(" << v << ")";
      ASSERT_TRUE(same(chosen[l], v > 1.0 ? v : -v)) << v;
    }
  }
}

}  // namespace
}  // namespace imm
