// Full 2x2x2 Gauss integration of the total Lagrangian hexahedron
// (Cheng 2022 Eq. 5). Exact for the patch test; locks in bending on coarse
// meshes (docs/fem.md shows it).
#include "cosim/fem/fem/element_formulation.hpp"
#include "cosim/fem/fem/hex8.hpp"
#include "cosim/fem/fem/total_lagrangian.hpp"

namespace cosim::fem {
namespace {

class Hex8Full final : public ElementFormulation {
 public:
  std::string name() const override { return "full"; }
  void initialise(const Mesh& mesh, const Material& material, const FormulationOptions&) override {
    geometry_.build(mesh);
    material_ = &material;
  }
  void evaluate(std::size_t e, const Mat83& ue, Vec24& fe, Mat24* Ke, ElementEnergy& energy) const override {
    fe.setZero();
    if (Ke) Ke->setZero();
    for (int q = 0; q < 8; ++q)
      addMaterialPoint<8>(geometry_.grad(e, q), ue, geometry_.weight(e, q) * pointScale(e, q), *material_, fe, Ke,
                          energy.strain, 8 * e + static_cast<std::size_t>(q));
  }
  int pointsPerElement() const override { return 8; }
  void pointStates(std::size_t e, const Mat83& ue, MaterialPointState* out) const override {
    for (int q = 0; q < 8; ++q) pointStress<8>(geometry_.grad(e, q), ue, *material_, out[q].F, out[q].S, 8 * e + static_cast<std::size_t>(q));
  }

 private:
  hex8::ReferenceGeometry geometry_;
  const Material* material_ = nullptr;
};

const FormulationRegistry::Registrar kFull("full", [] { return std::make_unique<Hex8Full>(); });

}  // namespace
}  // namespace cosim::fem
