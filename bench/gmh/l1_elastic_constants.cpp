// Scene L1 (Liu, Sun, Fish 2016 Sec. 3.1, Table II): elastic constants of a
// unit cell from small-strain unit-cell jobs about its isotropic state.
//
//   l1_elastic_constants [--cell cell.ckpt | --count 500 --seed 1] [--strain 1e-5]
//                        [--tolerance 1e-4] [--max-steps 400000]
//
// From the relaxed reference state (stress sigma0), each test is one job on a
// copy of the cell, with strain e (tension positive, like the stress):
//   isotropic        d eps = -e I                 K = d p / (3 e), p = -tr(sigma) / 3
//   constrained 11   d eps_11 = -e (22, 33 too)   M = d sigma_aa / d eps_aa, lambda = d sigma_bb / d eps_aa,
//                                                 K_u = (M + 2 lambda) / 3, G_u = (M - lambda) / 2
//   simple shear 12  d eps_12 = d eps_21 = e / 2  G = d sigma_12 / (2 d eps_12) (13, 23 too)
// and E = 9 K G / (3 K + G), nu = (3 K - 2 G) / (2 (3 K + G)) from K (isotropic) and G (shear).
#include <array>
#include <chrono>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "cosim/dem/cell/unit_cell.hpp"
#include "cosim/dem/io/checkpoint.hpp"
#include "cosim/dem/measure/measures.hpp"

namespace {

using cosim::dem::DemSystem;

struct Response {
  std::array<double, 9> dSigma{};
  long steps = 0;
  double index = 0.0;
};

Response probe(const DemSystem& base, const std::array<double, 9>& strain, const cosim::dem::RelaxSettings& relax) {
  DemSystem cell = cosim::dem::cloneCell(base);
  const auto before = cosim::dem::measureCell(cell);
  const cosim::dem::JobOutcome o = cosim::dem::runUnitCellJob(cell, strain, relax);
  if (!o.problem().empty()) throw std::runtime_error("probe job failed: " + o.problem());
  Response r;
  for (std::size_t k = 0; k < 9; ++k) r.dSigma[k] = o.measures.stress[k] - before.stress[k];
  r.steps = o.steps;
  r.index = o.measures.unbalancedForceIndex;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::string cellFile;
  cosim::dem::CellPreparation prep;
  double e = 1e-5;
  cosim::dem::RelaxSettings relax;
  relax.tolerance = 1e-4;
  relax.maxSteps = 400000;
  try {
    for (int a = 1; a + 1 < argc; a += 2) {
      const std::string k = argv[a], v = argv[a + 1];
      if (k == "--cell") cellFile = v;
      else if (k == "--count") prep.count = std::stoul(v);
      else if (k == "--seed") prep.seed = std::stoul(v);
      else if (k == "--strain") e = std::stod(v);
      else if (k == "--tolerance") relax.tolerance = std::stod(v);
      else if (k == "--max-steps") relax.maxSteps = std::stol(v);
      else throw std::runtime_error("unknown option '" + k + "'");
    }
    if (argc % 2 == 0) throw std::runtime_error("options come in pairs: --key value");
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "l1_elastic_constants: %s\n", ex.what());
    return 2;
  }
  try {
    const auto start = std::chrono::steady_clock::now();
    DemSystem base;
    if (cellFile.empty()) {
      cosim::dem::PreparationLog log;
      base = cosim::dem::prepareUnitCell(prep, &log);
      relax.dt = log.dt;
    } else {
      cosim::dem::readCheckpoint(base, cellFile);
      relax.dt = 0.5 * cosim::dem::criticalTimeStep(base);  // the preparation's dt factor
    }
    // Reference state: the same relaxation tolerance as the probes, so the
    // differences measure the increment and not the relaxation.
    const cosim::dem::JobOutcome ref = cosim::dem::runUnitCellJob(base, {}, relax);
    if (!ref.problem().empty()) throw std::runtime_error("reference relaxation failed: " + ref.problem());
    const auto m0 = ref.measures;
    std::printf("cell: %zu spheres, porosity %.4f, Z %.3f, mean stress %.5g Pa (sigma diag %.5g %.5g %.5g), I_uf %.2e\n",
                base.particles.size(), m0.porosity, m0.coordination, -m0.pressure, m0.stress[0], m0.stress[4],
                m0.stress[8], m0.unbalancedForceIndex);
    std::printf("probes: strain %.1e, relaxation to I_uf < %.1e, dt %.3e s\n\n", e, relax.tolerance, relax.dt);

    const Response iso = probe(base, {-e, 0, 0, 0, -e, 0, 0, 0, -e}, relax);
    const double kIso = -(iso.dSigma[0] + iso.dSigma[4] + iso.dSigma[8]) / 3.0 / (3.0 * e);
    double mSum = 0.0, lSum = 0.0, gSum = 0.0;
    std::printf("%-16s %12s %12s %12s %12s %8s\n", "test", "dsig_11", "dsig_22", "dsig_33", "dsig_offdiag", "steps");
    std::printf("%-16s %12.5g %12.5g %12.5g %12.3g %8ld\n", "isotropic", iso.dSigma[0], iso.dSigma[4], iso.dSigma[8],
                iso.dSigma[1], iso.steps);
    for (std::size_t a = 0; a < 3; ++a) {
      std::array<double, 9> d{};
      d[4 * a] = -e;
      const Response r = probe(base, d, relax);
      const std::size_t b = (a + 1) % 3, c = (a + 2) % 3;
      mSum += r.dSigma[4 * a] / -e;
      lSum += 0.5 * (r.dSigma[4 * b] + r.dSigma[4 * c]) / -e;
      std::printf("constrained %zu%zu   %12.5g %12.5g %12.5g %12.3g %8ld\n", a + 1, a + 1, r.dSigma[0], r.dSigma[4],
                  r.dSigma[8], r.dSigma[3 * b + c], r.steps);
    }
    const std::array<std::array<std::size_t, 2>, 3> planes{{{0, 1}, {0, 2}, {1, 2}}};
    for (const auto& pl : planes) {
      std::array<double, 9> d{};
      d[3 * pl[0] + pl[1]] = d[3 * pl[1] + pl[0]] = 0.5 * e;
      const Response r = probe(base, d, relax);
      const double g = r.dSigma[3 * pl[0] + pl[1]] / e;
      gSum += g;
      std::printf("simple shear %zu%zu  %12.5g %12.5g %12.5g %12.5g %8ld\n", pl[0] + 1, pl[1] + 1, r.dSigma[0],
                  r.dSigma[4], r.dSigma[8], r.dSigma[3 * pl[0] + pl[1]], r.steps);
    }
    const double mMod = mSum / 3.0, lambda = lSum / 3.0, g = gSum / 3.0;
    const double kU = (mMod + 2.0 * lambda) / 3.0, gU = 0.5 * (mMod - lambda);
    const double eMod = 9.0 * kIso * g / (3.0 * kIso + g), nu = (3.0 * kIso - 2.0 * g) / (2.0 * (3.0 * kIso + g));
    std::printf("\n%-34s %10s %10s %10s %10s\n", "", "E [MPa]", "nu", "K [MPa]", "G [MPa]");
    std::printf("%-34s %10.0f %10.2f %10.0f %10.0f\n", "Liu 2016 Table II (4096 spheres)", 584.0, 0.2, 335.0, 241.0);
    std::printf("%-34s %10.0f %10.3f %10.0f %10.0f\n", "this cell: K isotropic, G shear", eMod / 1e6, nu, kIso / 1e6,
                g / 1e6);
    std::printf("%-34s %10s %10s %10.0f %10.0f\n", "this cell: constrained compression", "", "", kU / 1e6, gU / 1e6);
    std::printf("\n%.1f s wall\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "l1_elastic_constants: %s\n", ex.what());
    return 1;
  }
  return 0;
}
