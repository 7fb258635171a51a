#pragma once
// Correspondence output (Hartmann 2022 Eqs. 26-30): shape tensor, non-local
// deformation gradient, Green-Lagrange strain, Neo-Hookean PK2 and Cauchy
// stress, von Mises stress. Output only: forces come from the PdModel.
#include <vector>

#include "cosim/pd/model.hpp"

namespace cosim::pd {

struct CorrespondenceFields {
  std::vector<double> deformationGradient;  // 9 per particle, row-major F_ij
  std::vector<double> greenLagrange;        // 6 per particle: xx yy zz xy yz zx
  std::vector<double> pk2;                  // 6 per particle
  std::vector<double> cauchy;               // 6 per particle
  std::vector<double> vonMises;             // 1 per particle
};

/// Fields of the particles of one body (sizes scaled by end - begin). A
/// particle whose family is degenerate (singular shape tensor, e.g. fully
/// broken) gets F = I and zero stress.
CorrespondenceFields correspondence(const BodyContext& body);

}  // namespace cosim::pd
