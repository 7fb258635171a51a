#pragma once
// Nonlocal averaging of the unit cells' inelastic stress: a regularisation of
// GMH that is ours, not Liu's. Liu's operator (Eqs. 58-59, NonlocalOperator)
// averages the strain increments the cells receive. Averaging the total strain
// does not bound the zone where the cells soften: any field of cell strains is
// reached by some field of element strains (e = A eps can be inverted on a
// mesh), so the softening cells can gather in one element row, and the
// alternating patterns the kernel removes cost nothing (Bazant and Chang 1984,
// "Instability of nonlocal continuum and strain averaging"; Bazant and Jirasek
// 2002, J. Eng. Mech. 128(11), Sec. 4). What the literature regularises
// instead is the inelastic part of the response. A DEM cell has no internal
// variable to average, so the inelastic stress is measured against an
// isotropic stiffness C (in the spirit of the nonlocal inelastic-stress forms
// Bazant and Jirasek 2002 survey):
//   s_I = C : eps_I - (sigma_I - sigma_0I),
// eps_I the strain the cell was given (the sum of its increments), sigma_0I its
// stress before the first increment. FEM then gets, with A the bell operator
// of Eq. A.4 and m the over-nonlocal factor (Vermeer and Brinkgreve 1994),
//   sigma*_I = C : eps_I - [(1 - m) s_I + m <s>_I]  =  sigma_I + m (s_I - <s>_I);
// for m = 1, sigma* = <sigma> + C : (eps - <eps>). Each cell keeps its own
// state (it sees its own increments). A uniform field is left as it is, and an
// elastic cell too when C is its elastic stiffness. For a pattern with
// eigenvalue lambda of A the tangent is (1 - m (1 - lambda)) C_t + m (1 - lambda) C:
// smooth patterns (lambda near 1) soften with the cells, patterns alternating
// within R (lambda near 0) keep m C, so softening can only spread over a zone
// of the order of R. C is a model parameter: the cells' elastic stiffness is
// its upper end, and with it a specimen a few R wide stiffens wherever its
// plastic strain is not uniform (docs/gmh_unit_cells.md, L5). m above 1 also
// needs C > C_t (1 - 1/m) to keep those patterns stiff.
#include <array>
#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "cosim/coupler/mapping/nonlocal_operator.hpp"

namespace cosim::util {
class BinaryWriter;
class BinaryReader;
}  // namespace cosim::util

namespace cosim::coupler {

class InelasticStressAveraging {
 public:
  /// C (Young's modulus, Poisson's ratio; the cells' own elastic stiffness,
  /// which bench/gmh/l1_elastic_constants measures, is its upper end) and m > 0.
  InelasticStressAveraging(double youngsModulus, double poissonRatio, double overNonlocal);

  /// sigma_0: the cells' stresses before their first increment (9 per cell, row-major).
  void setReference(std::span<const std::uint32_t> ids, std::span<const double> stresses);
  bool hasReference() const { return !reference_.empty(); }
  /// The increments just sent (9 per cell); they count once the cells answer.
  void send(std::span<const std::uint32_t> ids, std::span<const double> increments);
  /// The cells answered the increments sent last: eps += d eps (symmetric part).
  void answered(std::span<const std::uint32_t> ids);

  /// sigma_I -> sigma_I + m (s_I - <s>_I) for the cells `ids` (stresses aligned
  /// with them); `pointIds` names the operator's points in its order, and
  /// every one of them must be among `ids`. Returns the RMS over the cells
  /// of the correction's Frobenius norm [Pa].
  double correct(const NonlocalOperator& op, std::span<const std::uint32_t> pointIds,
                 std::span<const std::uint32_t> ids, std::span<double> stresses);

  /// C : eps for a strain of 9 components (row-major, symmetrised).
  std::array<double, 9> elasticStress(const std::array<double, 9>& strain) const;
  double overNonlocal() const { return m_; }

  void save(util::BinaryWriter& out) const;
  void restore(util::BinaryReader& in);

 private:
  double lambda_, shear_, m_;
  std::map<std::uint32_t, std::array<double, 9>> reference_, strain_, pending_;
  std::vector<double> inelastic_, averaged_;  // per operator point, 9 each: reused buffers
  std::vector<std::size_t> row_;              // per operator point: its row in `ids`
};

}  // namespace cosim::coupler
