// dem_prepare_cell: builds a GMH unit cell (Liu, Sun, Fish 2016 Sec. 3.1): a
// random polydisperse packing in a periodic cell, compressed by a stress servo
// on the cell to an isotropic pressure and relaxed until the unbalanced-force
// index (Liu Eq. 57) is below tolerance. Writes OUT.ckpt (what dem_solver's
// unit_cells mode loads) and OUT.h5 (positions, radii, contacts, /cell/h).
//
//   dem_prepare_cell --out cell500 [--count 500] [--seed 1] [--pressure 416e3]
//                    [--friction 0.5] [--damping 0.12] [--keep-friction]
//                    [--tolerance 0.01] [--remove 25] [--max-steps 2000000]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <functional>
#include <map>
#include <string>

#include "cosim/dem/cell/unit_cell.hpp"

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: dem_prepare_cell --out BASE [--count N] [--seed S] [--pressure Pa] [--friction mu]\n"
               "       [--damping zeta] [--keep-friction] [--tolerance I_uf] [--pressure-tolerance rel]\n"
               "       [--solid-fraction phi0] [--remove K] [--max-steps N] [--d-min m] [--d-max m]\n");
}

double number(const std::string& key, const std::string& text) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size()) throw std::runtime_error(key + ": expected a number, got '" + text + "'");
  return v;
}

void print(const char* what, const cosim::dem::DemSystem& cell) {
  const cosim::dem::CellMeasures m = cosim::dem::measureCell(cell);
  std::printf("%s: %zu spheres, cell %.4g mm wide, porosity %.4f, Z %.3f, I_uf %.2e\n", what, cell.particles.size(),
              1e3 * cell.cell.width(0), m.porosity, m.coordination, m.unbalancedForceIndex);
  std::printf("  stress diag [%.5g %.5g %.5g] Pa, off-diag [%.3g %.3g %.3g] Pa, mean %.5g Pa\n", m.stress[0],
              m.stress[4], m.stress[8], m.stress[1], m.stress[2], m.stress[5], -m.pressure);
}

}  // namespace

int main(int argc, char** argv) {
  cosim::dem::CellPreparation prep;
  std::string out;
  long remove = 0;
  try {
    const std::map<std::string, std::function<void(const std::string&)>> options{
        {"--out", [&](const std::string& v) { out = v; }},
        {"--count", [&](const std::string& v) { prep.count = static_cast<std::size_t>(number("--count", v)); }},
        {"--seed", [&](const std::string& v) { prep.seed = static_cast<std::uint64_t>(number("--seed", v)); }},
        {"--pressure", [&](const std::string& v) { prep.pressure = number("--pressure", v); }},
        {"--friction", [&](const std::string& v) { prep.friction = number("--friction", v); }},
        {"--damping", [&](const std::string& v) { prep.contactDamping = number("--damping", v); }},
        {"--tolerance", [&](const std::string& v) { prep.unbalancedTolerance = number("--tolerance", v); }},
        {"--pressure-tolerance", [&](const std::string& v) { prep.pressureTolerance = number("--pressure-tolerance", v); }},
        {"--solid-fraction", [&](const std::string& v) { prep.initialSolidFraction = number("--solid-fraction", v); }},
        {"--max-steps", [&](const std::string& v) { prep.maxSteps = static_cast<long>(number("--max-steps", v)); }},
        {"--d-min", [&](const std::string& v) { prep.dMin = number("--d-min", v); }},
        {"--d-max", [&](const std::string& v) { prep.dMax = number("--d-max", v); }},
        {"--remove", [&](const std::string& v) { remove = static_cast<long>(number("--remove", v)); }},
    };
    for (int a = 1; a < argc; ++a) {
      const std::string key = argv[a];
      if (key == "--keep-friction") {
        prep.frictionlessCompression = false;
        continue;
      }
      const auto it = options.find(key);
      if (it == options.end()) throw std::runtime_error("unknown option '" + key + "'");
      if (a + 1 >= argc) throw std::runtime_error(key + ": missing value");
      it->second(argv[++a]);
    }
    if (out.empty()) throw std::runtime_error("--out is required");
    if (remove < 0) throw std::runtime_error("--remove must not be negative");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dem_prepare_cell: %s\n", e.what());
    usage();
    return 2;
  }
  try {
    const auto start = std::chrono::steady_clock::now();
    cosim::dem::PreparationLog log;
    prep.progress = [&prep](long steps, double pressure, double unbalanced) {
      std::fprintf(stderr, "dem_prepare_cell: servo step %ld, mean stress %.1f kPa of %.1f kPa, I_uf %.3g\n", steps,
                   pressure / 1e3, prep.pressure / 1e3, unbalanced);
    };
    cosim::dem::DemSystem cell = cosim::dem::prepareUnitCell(prep, &log);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("dt %.3e s, mass damping %.3e 1/s; compression %ld steps (%s: porosity %.4f, Z %.3f), "
                "friction on: %ld steps; %.1f s wall\n",
                log.dt, cell.massDamping, log.compressionSteps, prep.frictionlessCompression ? "mu = 0" : "mu on",
                log.frictionlessPorosity, log.frictionlessCoordination, log.frictionSteps, seconds);
    print("prepared", cell);
    cosim::dem::saveUnitCell(cell, out, log.dt);
    std::printf("wrote %s.ckpt and %s.h5\n", out.c_str(), out.c_str());
    if (remove > 0) {
      const cosim::dem::DemSystem weak = cosim::dem::weakenedCell(cell, static_cast<std::size_t>(remove), prep.seed + 1,
                                                                  log.dt, prep.unbalancedTolerance, prep.maxSteps);
      print("weakened", weak);
      cosim::dem::saveUnitCell(weak, out + "_weak", log.dt);
      std::printf("wrote %s_weak.ckpt and %s_weak.h5\n", out.c_str(), out.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dem_prepare_cell: %s\n", e.what());
    return 1;
  }
  return 0;
}
