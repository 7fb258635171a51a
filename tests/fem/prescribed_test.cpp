// Prescribed time functions: the ramp and constant rate, and the sine of a
// given frequency (cyclic end load of Liu 2016 Sec. 3.3) against its formula,
// its velocity against the derivative of its displacement, and the model's
// refusal of a bad frequency.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

TEST(FemPrescribed, SineDisplacementAndItsVelocity) {
  const double a = 1.0e-4, f = 1.0e4, w = 2.0 * std::numbers::pi * f;
  const Prescribed p{0, Prescribed::Kind::displacement, a, 0.0, f};
  // Quarter periods: 0, peak, 0, trough; and an arbitrary time.
  EXPECT_EQ(p.displacement(0.0), 0.0);
  EXPECT_NEAR(p.displacement(0.25e-4), a, 1e-15);
  EXPECT_NEAR(p.displacement(0.5e-4), 0.0, 1e-15);
  EXPECT_NEAR(p.displacement(0.75e-4), -a, 1e-15);
  EXPECT_NEAR(p.displacement(3.7e-5), a * std::sin(w * 3.7e-5), 1e-18);
  EXPECT_NEAR(p.velocity(0.0), a * w, 1e-12);                      // 6.28 m/s: the sine starts at full speed
  EXPECT_NEAR(p.velocity(0.25e-4), 0.0, 1e-10);
  EXPECT_NEAR(p.velocity(0.5e-4), -a * w, 1e-12);
  // v = du/dt (central difference over 1e-10 s).
  for (double t : {1e-6, 2.3e-5, 6.1e-5, 9.9e-4}) {
    const double h = 1e-10;
    EXPECT_NEAR(p.velocity(t), (p.displacement(t + h) - p.displacement(t - h)) / (2 * h), 1e-6 * a * w) << t;
  }
}

TEST(FemPrescribed, SineVelocityAndItsDisplacement) {
  const double v0 = 0.5, f = 200.0, w = 2.0 * std::numbers::pi * f;
  const Prescribed p{0, Prescribed::Kind::velocity, v0, 0.0, f};
  EXPECT_EQ(p.displacement(0.0), 0.0);
  EXPECT_EQ(p.velocity(0.0), 0.0);
  EXPECT_NEAR(p.velocity(1.25e-3), v0, 1e-15);                    // quarter period
  EXPECT_NEAR(p.displacement(2.5e-3), 2.0 * v0 / w, 1e-15);       // half period: the largest excursion
  EXPECT_NEAR(p.displacement(5.0e-3), 0.0, 1e-15);                // one period: back at the start
  for (double t : {1e-4, 1.7e-3, 4.2e-3}) {
    EXPECT_NEAR(p.displacement(t), v0 * (1.0 - std::cos(w * t)) / w, 1e-15) << t;
    const double h = 1e-9;
    EXPECT_NEAR(p.velocity(t), (p.displacement(t + h) - p.displacement(t - h)) / (2 * h), 1e-6 * v0) << t;
  }
}

TEST(FemPrescribed, ZeroFrequencyKeepsTheRampAndTheConstantRate) {
  const Prescribed ramp{0, Prescribed::Kind::displacement, 2.0, 0.5, 0.0};
  EXPECT_DOUBLE_EQ(ramp.displacement(0.25), 1.0);
  EXPECT_DOUBLE_EQ(ramp.displacement(3.0), 2.0);
  EXPECT_DOUBLE_EQ(ramp.velocity(0.25), 4.0);
  EXPECT_DOUBLE_EQ(ramp.velocity(3.0), 0.0);
  const Prescribed rate{0, Prescribed::Kind::velocity, 2.0, 0.0, 0.0};
  EXPECT_DOUBLE_EQ(rate.displacement(0.25), 0.5);
  EXPECT_DOUBLE_EQ(rate.velocity(0.25), 2.0);
}

TEST(FemPrescribed, ModelRefusesABadFrequency) {
  auto model = test::makeModel(makeBoxMesh({0, 0, 0}, {1, 1, 1}, {1, 1, 1}), "one-point", 1e8, 0.2, 1000.0);
  EXPECT_THROW(model->prescribe(0, 1, Prescribed::Kind::displacement, 1e-3, 0.0, -1.0), InputError);
  EXPECT_THROW(model->prescribe(0, 1, Prescribed::Kind::displacement, 1e-3, 0.0, std::nan("")), InputError);
  model->prescribe(0, 1, Prescribed::Kind::displacement, 1e-3, 0.0, 50.0);
  ASSERT_EQ(model->prescribed().size(), 1u);
  EXPECT_EQ(model->prescribed()[0].frequency, 50.0);
}

}  // namespace
}  // namespace cosim::fem
