// Direct-DEM counterpart of scene L4 reduced (Liu, Sun, Fish 2016 Sec. 3.4:
// "22 h for the multiscale run against about a month for direct DEM"), for
// the cost ratio the GMH issue asks for: one DEM sample with the same spheres
// as the reduced GMH run, sheared at the same nominal rate with the same
// grains, contact law and fine time step.
//
//   l4_direct_dem --cell cell.ckpt [--weak cell_weak.ckpt] [--tiles 5,12,1] [--weak-tile 2,9,0]
//                 [--rate 5] [--strain 0.01] [--warmup 200]      (threads: OMP_NUM_THREADS)
//
// The sample is the prepared unit cell tiled nx x ny x nz times, the L4
// layout with one cell per element (the weakened cell in its element), so it
// starts at the cells' 416 kPa and holds exactly the GMH run's spheres. It is
// sheared as a periodic Lees-Edwards cell, L = rate e_x (x) e_y (x along the
// height y, as the top of L4 moves), at the cells' own time step (half the
// Rayleigh-Hertz critical step, what the GMH workers use), with the cells'
// contact damping and no mass damping: dynamic DEM, not dynamic relaxation.
// It prints particle-steps/s and the wall time per 1 % of shear strain, the
// quantity bench/gmh/l4_cost_ratio.sh divides by the GMH run's.
// Departures: the paper's direct sample had rough walls top and bottom; a
// periodic cell has no boundary layer and cannot dilate (constant volume).
// The per-step cost, which the ratio is about, is that of any DEM sample with
// these spheres. Contact histories start at zero across the tile faces.
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cosim/dem/cell/unit_cell.hpp"
#include "cosim/dem/io/checkpoint.hpp"
#include "cosim/dem/measure/measures.hpp"
#include "cosim/dem/parallel.hpp"

namespace {

using cosim::dem::DemSystem;
using cosim::dem::Vec3;

std::array<int, 3> triple(const std::string& key, const std::string& text) {
  std::array<int, 3> t{};
  char c1 = 0, c2 = 0;
  std::istringstream in(text);
  if (!(in >> t[0] >> c1 >> t[1] >> c2 >> t[2]) || c1 != ',' || c2 != ',')
    throw std::runtime_error(key + " needs three integers a,b,c, got '" + text + "'");
  return t;
}

/// Appends the spheres of `from` shifted by `offset`, with their materials and kinematics.
void appendShifted(DemSystem& to, const DemSystem& from, const Vec3& offset) {
  const cosim::dem::Particles& p = from.particles;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::size_t k = to.particles.add(p.x[i] + offset, p.radius[i], from.materials[p.material[i]].density, p.material[i]);
    to.particles.v[k] = p.v[i];
    to.particles.omega[k] = p.omega[i];
    to.particles.q[k] = p.q[i];
  }
}

/// The cell tiled n[0] x n[1] x n[2] times, `weak` in tile weakTile (when given).
DemSystem tiledSample(const DemSystem& cell, const DemSystem* weak, const std::array<int, 3>& n,
                      const std::array<int, 3>& weakTile) {
  DemSystem sample = cosim::dem::cloneCell(cell);  // materials, law, skin, cell shape
  sample.particles = cosim::dem::Particles{};
  sample.particles.reserve(cell.particles.size() * static_cast<std::size_t>(n[0] * n[1] * n[2]));
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        const bool isWeak = weak && std::array<int, 3>{i, j, k} == weakTile;
        appendShifted(sample, isWeak ? *weak : cell,
                      cell.cell.shift({static_cast<std::int8_t>(i), static_cast<std::int8_t>(j), static_cast<std::int8_t>(k)}));
      }
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t r = 0; r < 3; ++r) sample.cell.h[3 * r + c] *= n[c];
  sample.cell.velocityGradient = {};
  sample.massDamping = 0.0;
  sample.excludedPairs.clear();
  sample.neighbors = cosim::dem::NeighborList{};
  sample.neighbors.skin = cell.neighbors.skin;
  sample.initialize();
  return sample;
}

double seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

int main(int argc, char** argv) {
  std::string cellFile, weakFile;
  std::array<int, 3> tiles{5, 12, 1}, weakTile{2, 9, 0};
  double rate = 5.0, strain = 0.01;
  long warmup = 200;
  try {
    if (argc % 2 == 0) throw std::runtime_error("options come in pairs: --key value");
    for (int a = 1; a + 1 < argc; a += 2) {
      const std::string k = argv[a], v = argv[a + 1];
      if (k == "--cell") cellFile = v;
      else if (k == "--weak") weakFile = v;
      else if (k == "--tiles") tiles = triple(k, v);
      else if (k == "--weak-tile") weakTile = triple(k, v);
      else if (k == "--rate") rate = std::stod(v);
      else if (k == "--strain") strain = std::stod(v);
      else if (k == "--warmup") warmup = std::stol(v);
      else throw std::runtime_error("unknown option '" + k + "'");
    }
    if (cellFile.empty()) throw std::runtime_error("--cell is required");
    for (int t : tiles)
      if (t < 1 || t > 100) throw std::runtime_error("--tiles entries must be in [1, 100]");
    if (!(rate > 0.0) || !(strain > 0.0) || warmup < 0) throw std::runtime_error("--rate and --strain must be > 0, --warmup >= 0");
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "l4_direct_dem: %s\n", ex.what());
    return 2;
  }
  try {
    DemSystem cell, weak;
    cosim::dem::readCheckpoint(cell, cellFile);
    if (!cell.cell.enabled) throw std::runtime_error(cellFile + ": not a periodic unit cell");
    if (!weakFile.empty()) cosim::dem::readCheckpoint(weak, weakFile);
    const double dt = 0.5 * cosim::dem::criticalTimeStep(cell);  // the GMH workers' step (dt_factor 0.5)
    const auto setupStart = std::chrono::steady_clock::now();
    DemSystem sample = tiledSample(cell, weakFile.empty() ? nullptr : &weak, tiles, weakTile);
    const auto m0 = cosim::dem::measureCell(sample);
    std::printf("sample: %d x %d x %d tiles of %s%s, %zu spheres, porosity %.4f, Z %.3f, pressure %.4g Pa "
                "(setup %.1f s)\n", tiles[0], tiles[1], tiles[2], cellFile.c_str(),
                weakFile.empty() ? "" : (", weakened tile " + std::to_string(weakTile[0]) + "," +
                                         std::to_string(weakTile[1]) + "," + std::to_string(weakTile[2])).c_str(),
                sample.particles.size(), m0.porosity, m0.coordination, m0.pressure, seconds(setupStart));
    sample.cell.velocityGradient = {0.0, rate, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (long s = 0; s < warmup; ++s) sample.advance(dt);
    const long steps = std::lround(strain / (rate * dt));
    const auto start = std::chrono::steady_clock::now();
    for (long s = 0; s < steps; ++s) sample.advance(dt);
    const double wall = seconds(start);
    const auto m1 = cosim::dem::measureCell(sample);
    if (!std::isfinite(m1.stress[1]) || !std::isfinite(m1.pressure))
      throw std::runtime_error("the sample's stress is not finite after the timed steps");
    const double n = static_cast<double>(sample.particles.size());
    const double perPercent = wall / (strain / 0.01);
    std::printf("dt %.4g s (half the critical step), rate %.4g 1/s, %ld warm-up + %ld timed steps (shear strain %.4g), "
                "%d thread(s)\n", dt, rate, warmup, steps, strain, cosim::dem::threadCount());
    std::printf("end state: shear stress sigma_xy %.4g Pa, pressure %.4g Pa, Z %.3f\n", m1.stress[1], m1.pressure,
                m1.coordination);
    std::printf("speed: %.4g M particle-steps/s, %.3f s wall per step\n", n * static_cast<double>(steps) / wall / 1e6,
                wall / static_cast<double>(steps));
    std::printf("wall per 1 %% shear strain: %.2f s; extrapolated to 12 %%: %.0f s, to 20 %%: %.0f s\n", perPercent,
                12.0 * perPercent, 20.0 * perPercent);
    std::printf("direct_dem_wall_per_percent %.6g\n", perPercent);
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "l4_direct_dem: %s\n", ex.what());
    return 1;
  }
  return 0;
}
