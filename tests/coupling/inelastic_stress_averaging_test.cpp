// Nonlocal averaging of the unit cells' inelastic stress (ours, not Liu's):
// s = C : eps - (sigma - sigma_0), FEM gets sigma + m (s - <s>). Elastic cells
// and uniform fields are left alone; a softened cell hands the share of its
// inelastic stress that its neighbours do not share back as stiffness.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "cosim/coupler/mapping/inelastic_stress_averaging.hpp"
#include "cosim/util/binary_record.hpp"

namespace cosim::coupler {
namespace {

using Tensor = std::array<double, 9>;

constexpr double kE = 7.56e8, kNu = 0.113;

/// Points in a row along x, spacing h.
std::vector<double> row(int n, double h) {
  std::vector<double> x;
  for (int i = 0; i < n; ++i) x.insert(x.end(), {i * h, 0.0, 0.0});
  return x;
}

std::vector<double> isotropic(std::size_t cells, double p) {
  std::vector<double> s(9 * cells, 0.0);
  for (std::size_t k = 0; k < cells; ++k) s[9 * k] = s[9 * k + 4] = s[9 * k + 8] = -p;
  return s;
}

TEST(InelasticStressAveraging, ElasticStressIsIsotropicHookeOfTheSymmetricStrain) {
  const InelasticStressAveraging avg(kE, kNu, 1.0);
  const double lambda = kE * kNu / ((1 + kNu) * (1 - 2 * kNu)), g = kE / (2 * (1 + kNu));
  const Tensor uniaxial = avg.elasticStress({-1e-4, 0, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_NEAR(uniaxial[0], -(lambda + 2 * g) * 1e-4, 1e-9 * kE);
  EXPECT_NEAR(uniaxial[4], -lambda * 1e-4, 1e-9 * kE);
  EXPECT_NEAR(uniaxial[8], -lambda * 1e-4, 1e-9 * kE);
  // A displacement gradient with spin: only its symmetric part strains.
  const Tensor shear = avg.elasticStress({0, 2e-4, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_NEAR(shear[1], g * 2e-4, 1e-9 * kE);
  EXPECT_NEAR(shear[3], g * 2e-4, 1e-9 * kE);
  EXPECT_EQ(shear[0], 0.0);
}

TEST(InelasticStressAveraging, ElasticCellsAndAUniformSofteningAreLeftAlone) {
  const auto x = row(5, 0.01);
  const NonlocalOperator op(x, 0.025);
  const std::vector<std::uint32_t> ids{0, 1, 2, 3, 4};
  InelasticStressAveraging avg(kE, kNu, 1.0);
  avg.setReference(ids, isotropic(5, 416e3));
  // Different strains per cell, each cell answering exactly C : eps: s = 0.
  std::vector<double> inc(45, 0.0);
  for (int k = 0; k < 5; ++k) inc[9 * k + 4] = -1e-5 * (k + 1), inc[9 * k + 1] = 3e-6 * k;
  avg.send(ids, inc);
  avg.answered(ids);
  std::vector<double> sigma = isotropic(5, 416e3);
  for (int k = 0; k < 5; ++k) {
    Tensor e{};
    e[4] = -1e-5 * (k + 1), e[1] = e[3] = 1.5e-6 * k;
    const auto c = avg.elasticStress(e);
    for (int i = 0; i < 9; ++i) sigma[9 * k + i] += c[i];
  }
  auto out = sigma;
  EXPECT_LT(avg.correct(op, ids, ids, out), 1e-9 * 416e3);
  for (std::size_t i = 0; i < out.size(); ++i) EXPECT_NEAR(out[i], sigma[i], 1e-9 * 416e3);

  // Every cell softened alike (same strain, same stress): <s> = s, nothing changes.
  InelasticStressAveraging uniform(kE, kNu, 2.0);
  uniform.setReference(ids, isotropic(5, 416e3));
  std::vector<double> same(45, 0.0);
  for (int k = 0; k < 5; ++k) same[9 * k + 4] = -2e-3;
  uniform.send(ids, same);
  uniform.answered(ids);
  std::vector<double> soft = isotropic(5, 300e3);
  auto kept = soft;
  EXPECT_LT(uniform.correct(op, ids, ids, kept), 1e-6);
  for (std::size_t i = 0; i < kept.size(); ++i) EXPECT_NEAR(kept[i], soft[i], 1e-9 * 416e3);
}

TEST(InelasticStressAveraging, ASoftenedCellGetsBackWhatItsNeighboursDoNotShare) {
  // Three points h apart, R = 2h: weights 1 and w = (1 - 1/4)^2 = 0.5625 to the
  // next point. Only the middle cell (id 7) softened, by d = 50 kPa in
  // sigma_yy: s_yy = (0, -d, 0). The middle's mean <s> = -d / (1 + 2w), an
  // end's <s> = -w d / (1 + w); FEM gets sigma + m (s - <s>).
  const double h = 0.01, w = 0.5625, d = 50e3, m = 1.5;
  const NonlocalOperator op(row(3, h), 2 * h);
  const std::vector<std::uint32_t> pointIds{5, 7, 9};
  const std::vector<std::uint32_t> answerIds{9, 5, 7};  // the workers' order differs from the operator's
  InelasticStressAveraging avg(kE, kNu, m);
  avg.setReference(answerIds, isotropic(3, 416e3));
  std::vector<double> sigma = isotropic(3, 416e3);
  sigma[9 * 2 + 4] += d;  // id 7 lost d of compression without being strained
  auto out = sigma;
  const double rms = avg.correct(op, pointIds, answerIds, out);
  // s_yy = -d at the middle, 0 at the ends (the point 2h away has weight 0).
  const double middle = m * (-d + d / (1 + 2 * w));
  const double end = m * (0.0 + d * w / (1 + w));
  EXPECT_NEAR(out[9 * 2 + 4] - sigma[9 * 2 + 4], middle, 1e-9 * d);
  EXPECT_NEAR(out[9 * 1 + 4] - sigma[9 * 1 + 4], end, 1e-9 * d);  // id 5
  EXPECT_NEAR(out[9 * 0 + 4] - sigma[9 * 0 + 4], end, 1e-9 * d);  // id 9
  EXPECT_NEAR(rms, std::sqrt((middle * middle + 2 * end * end) / 3.0), 1e-9 * d);
  // The softened cell is stiffened back towards its elastic stress, its neighbours softened.
  EXPECT_LT(out[9 * 2 + 4], sigma[9 * 2 + 4]);
  EXPECT_GT(out[9 * 1 + 4], sigma[9 * 1 + 4]);
}

TEST(InelasticStressAveraging, IncrementsCountOnceTheCellsAnswer) {
  const NonlocalOperator op(row(2, 0.01), 0.001);  // R below the spacing: <s> = s, no correction
  const std::vector<std::uint32_t> ids{0, 1};
  InelasticStressAveraging avg(kE, kNu, 1.0);
  avg.setReference(ids, isotropic(2, 416e3));
  std::vector<double> inc(18, 0.0);
  inc[0] = -1e-4;
  avg.send(ids, inc);
  // Not answered yet: no strain. Answered twice: counted once.
  InelasticStressAveraging copy = avg;
  avg.answered(ids);
  avg.answered(ids);
  std::ostringstream bytes;
  util::BinaryWriter w(bytes);
  avg.save(w);
  std::istringstream in(bytes.str());
  util::BinaryReader r(in, "test checkpoint");
  InelasticStressAveraging back(kE, kNu, 1.0);
  back.restore(r);
  // The saved strain comes back: the elastic answer to it leaves s = 0 in the
  // restored object, while the object that never saw the answer sees s != 0.
  const NonlocalOperator both(row(2, 0.01), 0.02);
  std::vector<double> sigma = isotropic(2, 416e3);
  const auto c = back.elasticStress({-1e-4, 0, 0, 0, 0, 0, 0, 0, 0});
  for (int i = 0; i < 9; ++i) sigma[i] += c[i];
  auto a = sigma, b = sigma;
  EXPECT_LT(back.correct(both, ids, ids, a), 1e-6);
  EXPECT_GT(copy.correct(both, ids, ids, b), 1e3);
}

TEST(InelasticStressAveraging, BadInputIsRefused) {
  EXPECT_THROW(InelasticStressAveraging(0.0, 0.2, 1.0), std::invalid_argument);
  EXPECT_THROW(InelasticStressAveraging(1e8, 0.5, 1.0), std::invalid_argument);
  EXPECT_THROW(InelasticStressAveraging(1e8, 0.2, 0.0), std::invalid_argument);
  const NonlocalOperator op(row(2, 0.01), 0.02);
  InelasticStressAveraging avg(kE, kNu, 1.0);
  const std::vector<std::uint32_t> ids{0, 1}, one{0};
  std::vector<double> sigma = isotropic(2, 416e3), single = isotropic(1, 416e3);
  try {
    avg.correct(op, ids, ids, sigma);
    FAIL() << "no reference accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("unit cell 0 has no reference stress"), std::string::npos) << e.what();
  }
  avg.setReference(ids, isotropic(2, 416e3));
  try {
    avg.correct(op, ids, one, single);
    FAIL() << "a missing answer accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("unit cell 1 did not answer"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cosim::coupler
