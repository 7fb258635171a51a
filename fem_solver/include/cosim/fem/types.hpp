#pragma once
// Small fixed-size algebra types shared by the FEM library.
#include <Eigen/Core>
#include <Eigen/Dense>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace cosim::fem {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec24 = Eigen::Matrix<double, 24, 1>;
using Mat24 = Eigen::Matrix<double, 24, 24, Eigen::RowMajor>;
using Mat83 = Eigen::Matrix<double, 8, 3>;  // one row per node: xyz
using Index = std::uint32_t;

/// Bad input (mesh, config, set names): the message names the entity.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A failed computation (divergence, NaN, singular system): names step/entity.
class SolveError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace cosim::fem
