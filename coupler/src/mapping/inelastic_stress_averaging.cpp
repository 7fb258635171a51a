#include "cosim/coupler/mapping/inelastic_stress_averaging.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "cosim/util/binary_record.hpp"

namespace cosim::coupler {
namespace {

using Tensor = std::array<double, 9>;

Tensor tensorAt(std::span<const double> values, std::size_t k) {
  Tensor t;
  for (std::size_t c = 0; c < 9; ++c) t[c] = values[9 * k + c];
  return t;
}

std::vector<std::uint32_t> keysOf(const std::map<std::uint32_t, Tensor>& m) {
  std::vector<std::uint32_t> k;
  for (const auto& [id, t] : m) k.push_back(id);
  return k;
}

std::vector<double> valuesOf(const std::map<std::uint32_t, Tensor>& m) {
  std::vector<double> v;
  for (const auto& [id, t] : m) v.insert(v.end(), t.begin(), t.end());
  return v;
}

std::map<std::uint32_t, Tensor> readTensors(util::BinaryReader& in, const char* ids, const char* values) {
  const auto k = in.vec<std::uint32_t>(ids);
  const auto v = in.vec<double>(values);
  if (v.size() != 9 * k.size()) in.fail(values, "not 9 values per cell");
  std::map<std::uint32_t, Tensor> m;
  for (std::size_t i = 0; i < k.size(); ++i) m[k[i]] = tensorAt(v, i);
  return m;
}

}  // namespace

InelasticStressAveraging::InelasticStressAveraging(double youngsModulus, double poissonRatio, double overNonlocal)
    : m_(overNonlocal) {
  if (!(youngsModulus > 0.0) || !std::isfinite(youngsModulus))
    throw std::invalid_argument("stiffness E must be positive, got " + std::to_string(youngsModulus));
  if (!(poissonRatio > -1.0 && poissonRatio < 0.5))
    throw std::invalid_argument("stiffness nu must lie in (-1, 0.5), got " + std::to_string(poissonRatio));
  if (!(overNonlocal > 0.0) || !std::isfinite(overNonlocal))
    throw std::invalid_argument("over-nonlocal factor must be positive, got " + std::to_string(overNonlocal));
  lambda_ = youngsModulus * poissonRatio / ((1.0 + poissonRatio) * (1.0 - 2.0 * poissonRatio));
  shear_ = youngsModulus / (2.0 * (1.0 + poissonRatio));
}

void InelasticStressAveraging::setReference(std::span<const std::uint32_t> ids, std::span<const double> stresses) {
  for (std::size_t k = 0; k < ids.size(); ++k) reference_[ids[k]] = tensorAt(stresses, k);
}

void InelasticStressAveraging::send(std::span<const std::uint32_t> ids, std::span<const double> increments) {
  pending_.clear();
  for (std::size_t k = 0; k < ids.size(); ++k) pending_[ids[k]] = tensorAt(increments, k);
}

void InelasticStressAveraging::answered(std::span<const std::uint32_t> ids) {
  for (std::uint32_t id : ids) {
    auto p = pending_.find(id);
    if (p == pending_.end()) continue;  // no job this step: its strain stands
    auto& eps = strain_[id];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) eps[3 * i + j] += 0.5 * (p->second[3 * i + j] + p->second[3 * j + i]);
    pending_.erase(p);
  }
}

std::array<double, 9> InelasticStressAveraging::elasticStress(const Tensor& strain) const {
  // Isotropic Hooke: C : eps = lambda tr(eps) I + 2 G sym(eps).
  const double volumetric = lambda_ * (strain[0] + strain[4] + strain[8]);
  Tensor s;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      s[3 * i + j] = shear_ * (strain[3 * i + j] + strain[3 * j + i]) + (i == j ? volumetric : 0.0);
  return s;
}

double InelasticStressAveraging::correct(const NonlocalOperator& op, std::span<const std::uint32_t> pointIds,
                                         std::span<const std::uint32_t> ids, std::span<double> stresses) {
  const std::size_t n = op.points();
  if (pointIds.size() != n || stresses.size() != 9 * ids.size())
    throw std::invalid_argument("inelastic stress averaging: " + std::to_string(pointIds.size()) + " point ids for " +
                                std::to_string(n) + " operator points, " + std::to_string(stresses.size()) +
                                " stress values for " + std::to_string(ids.size()) + " cells");
  std::map<std::uint32_t, std::size_t> rowOf;
  for (std::size_t k = 0; k < ids.size(); ++k) rowOf[ids[k]] = k;
  row_.resize(n), inelastic_.resize(9 * n), averaged_.resize(9 * n);
  for (std::size_t p = 0; p < n; ++p) {
    const std::uint32_t id = pointIds[p];
    const auto row = rowOf.find(id);
    const auto ref = reference_.find(id);
    if (row == rowOf.end() || ref == reference_.end())
      throw std::runtime_error("inelastic stress averaging: unit cell " + std::to_string(id) +
                               (row == rowOf.end() ? " did not answer" : " has no reference stress"));
    row_[p] = row->second;
    const auto strain = strain_.find(id);
    const Tensor elastic = strain == strain_.end() ? Tensor{} : elasticStress(strain->second);
    for (std::size_t c = 0; c < 9; ++c)
      inelastic_[9 * p + c] = elastic[c] - (stresses[9 * row_[p] + c] - ref->second[c]);
  }
  op.apply(inelastic_, 9, averaged_);
  double sumSquares = 0.0;
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t c = 0; c < 9; ++c) {
      const double d = m_ * (inelastic_[9 * p + c] - averaged_[9 * p + c]);
      stresses[9 * row_[p] + c] += d;
      sumSquares += d * d;
    }
  return n ? std::sqrt(sumSquares / static_cast<double>(n)) : 0.0;
}

void InelasticStressAveraging::save(util::BinaryWriter& out) const {
  out.vec(keysOf(reference_)), out.vec(valuesOf(reference_));
  out.vec(keysOf(strain_)), out.vec(valuesOf(strain_));
}

void InelasticStressAveraging::restore(util::BinaryReader& in) {
  reference_ = readTensors(in, "reference cell ids", "reference cell stresses");
  strain_ = readTensors(in, "strained cell ids", "cell strains");
  pending_.clear();
}

}  // namespace cosim::coupler
