// Scene L2 (Liu, Sun, Fish 2016 Sec. 3.2, Fig. 6): a one-element GMH run
// against a direct DEM test of the same unit cell along the same strain path.
//
//   l2_compare --run DIR [--scene DIR/scene.effective.yaml] [--max-rms 0.02] [--perturb 1e-10]
//              [--increments spatial | corotational]
//
// DIR is a finished `coupler run` of a configs/gmh/l2_*.yaml scene: one FEM
// element (one-point, external material) whose nodes are all prescribed, so its
// deformation is homogeneous, and one dem_solver worker holding cell 0. From
// the scene this program builds the same worker (same cell file, dt, damping,
// tolerance, load steps); from the FEM snapshots it takes the element's
// deformation gradient F_n at every step (fitted to the 8 nodes: the one-point
// F, see fitF) and
// the stress GMH produced. The direct test drives the cell with the spatial
// increments d_n = log(F_n F_{n-1}^-1) (the full gradient, spin included, so
// its stress is the lab-frame Cauchy stress; the GMH cell gets FEM's
// corotational increments, Liu Eqs. 60-62, and FEM rotates the stress back).
// --increments corotational instead drives the direct cell with those same
// corotational increments (computed here from F, independently of fem_solver)
// and rotates its stress with R(F_n): that isolates the GMH loop (transport,
// pairing, rotation) from the choice of the Green-Naghdi frame.
//
// Pairing: fem_solver writes a GMH snapshot after predicting the next
// positions, so snapshot n holds the positions of step n and the stress the
// cells returned for step n - 1 (rotated with R(F_n) instead of R(F_{n-1}), an
// error of one step's rotation, d gamma / 2 <= 2e-4 of the deviator). GMH's
// stress at F_n is therefore snapshot n + 1's.
//
// Prints the table (strain, GMH and DEM stress of the two components that
// describe the test) and, per component, the RMS of the difference relative
// to the peak |stress| of the DEM curve (Liu's Fig. 6 comparison; target 2 %)
// and relative to the peak stress change, and the same RMS between two direct
// tests whose increments differ by 1e-10 (the chaos floor). --max-rms: exit 1 when the first
// measure exceeds it for either component.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "cosim/dem/cell/unit_cell.hpp"
#include "cosim/dem/cell/unit_cell_worker.hpp"
#include "cosim/io/h5_file.hpp"

namespace {

namespace fs = std::filesystem;
using M3 = std::array<double, 9>;  // row-major

bool isFinite(double v) { return std::isfinite(v); }

M3 mul(const M3& a, const M3& b) {
  M3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[3 * i + j] += a[3 * i + k] * b[3 * k + j];
  return c;
}

M3 inverse(const M3& m) {
  const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                     m[2] * (m[3] * m[7] - m[4] * m[6]);
  if (!(std::abs(det) > 1e-300)) throw std::runtime_error("singular 3x3 matrix");
  M3 r{m[4] * m[8] - m[5] * m[7], m[2] * m[7] - m[1] * m[8], m[1] * m[5] - m[2] * m[4],
       m[5] * m[6] - m[3] * m[8], m[0] * m[8] - m[2] * m[6], m[2] * m[3] - m[0] * m[5],
       m[3] * m[7] - m[4] * m[6], m[1] * m[6] - m[0] * m[7], m[0] * m[4] - m[1] * m[3]};
  for (double& v : r) v /= det;
  return r;
}

M3 transpose(const M3& m) { return {m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8]}; }

// Rotation of the polar decomposition F = R U (Higham's iteration
// R <- (R + R^-T) / 2, quadratic convergence; F is near I here).
M3 polarRotation(const M3& F) {
  M3 r = F;
  for (int k = 0; k < 50; ++k) {
    const M3 it = transpose(inverse(r));
    double change = 0.0;
    for (std::size_t i = 0; i < 9; ++i) {
      const double v = 0.5 * (r[i] + it[i]);
      change = std::max(change, std::abs(v - r[i]));
      r[i] = v;
    }
    if (change < 1e-15) break;
  }
  return r;
}

// log(I + A) = A - A^2/2 + A^3/3 - ...: the increment whose affine application
// (the cell's x <- x + dt L x over the load steps, i.e. exp(d) to O(d^2 / n))
// reproduces F_n F_{n-1}^-1. |A| is about 4e-4 per step, so four terms leave 1e-14.
M3 logOfIdentityPlus(const M3& a) {
  M3 term = a, out{};
  for (int k = 1; k <= 4; ++k) {
    for (std::size_t i = 0; i < 9; ++i) out[i] += ((k % 2) ? 1.0 : -1.0) * term[i] / k;
    term = mul(term, a);
  }
  return out;
}

// F from the 8 node positions: x - x_c = F (X - X_c) in the least-squares
// sense, F = (sum dx dX^T)(sum dX dX^T)^-1. For a rectangular box element this
// is exactly the one-point F (the trilinear shape-function gradients at the
// centre are +-1 / (4 L_j), the same weights), i.e. the F whose increments the
// GMH cell receives; the node residual is the hourglass (non-affine) part,
// which the one-point stress does not see. `worst` returns that residual.
M3 fitF(const std::vector<double>& X, const std::vector<double>& x, double& worst) {
  const std::size_t n = X.size() / 3;
  std::array<double, 3> Xc{}, xc{};
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t d = 0; d < 3; ++d) Xc[d] += X[3 * p + d] / n, xc[d] += x[3 * p + d] / n;
  M3 a{}, b{};
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t i = 0; i < 3; ++i)
      for (std::size_t j = 0; j < 3; ++j) {
        a[3 * i + j] += (x[3 * p + i] - xc[i]) * (X[3 * p + j] - Xc[j]);
        b[3 * i + j] += (X[3 * p + i] - Xc[i]) * (X[3 * p + j] - Xc[j]);
      }
  const M3 F = mul(a, inverse(b));
  worst = 0.0;
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t i = 0; i < 3; ++i) {
      double r = x[3 * p + i] - xc[i];
      for (std::size_t j = 0; j < 3; ++j) r -= F[3 * i + j] * (X[3 * p + j] - Xc[j]);
      worst = std::max(worst, std::abs(r));
    }
  return F;
}

fs::path findFile(const fs::path& dir, const std::string& name) {
  if (fs::exists(dir / name)) return dir / name;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename() == name) return e.path();
  throw std::runtime_error("no FEM snapshot file '" + name + "' under " + dir.string() +
                           " (the fem solver needs output: {every: 1, file: ...})");
}

struct Component {
  int row, col;
  const char* name;
};

}  // namespace

int main(int argc, char** argv) {
  fs::path runDir, sceneFile;
  double maxRms = -1.0, perturb = 1e-10;
  bool corotational = false;
  try {
    if (argc % 2 == 0) throw std::runtime_error("options come in pairs: --key value");
    for (int a = 1; a + 1 < argc; a += 2) {
      const std::string k = argv[a], v = argv[a + 1];
      if (k == "--run") runDir = v;
      else if (k == "--scene") sceneFile = v;
      else if (k == "--max-rms") maxRms = std::stod(v);
      else if (k == "--perturb") perturb = std::stod(v);
      else if (k == "--increments") {
        if (v != "spatial" && v != "corotational")
          throw std::runtime_error("--increments takes spatial or corotational, not '" + v + "'");
        corotational = v == "corotational";
      }
      else throw std::runtime_error("unknown option '" + k + "'");
    }
    if (runDir.empty()) throw std::runtime_error("--run DIR (a finished coupler run of configs/gmh/l2_*.yaml) is required");
    if (sceneFile.empty()) sceneFile = runDir / "scene.effective.yaml";
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "l2_compare: %s\n", ex.what());
    return 2;
  }
  try {
    const YAML::Node scene = YAML::LoadFile(sceneFile.string());
    std::unique_ptr<cosim::dem::UnitCellWorker> worker;
    std::string snapshotName;
    for (const auto& s : scene["solvers"]) {
      const std::string kind = s["kind"].as<std::string>();
      if (kind == "dem" && s["params"]["unit_cells"]) {
        if (worker) throw std::runtime_error(sceneFile.string() + ": L2 compares one worker, the scene has several");
        worker = cosim::dem::UnitCellWorker::fromParams(s["params"], sceneFile.string());
      } else if (kind == "fem") {
        if (!s["params"]["output"] || !s["params"]["output"]["file"])
          throw std::runtime_error(sceneFile.string() + ": solver '" + s["name"].as<std::string>() +
                                   "' needs params.output: {every: 1, file: NAME.h5}");
        snapshotName = s["params"]["output"]["file"].as<std::string>();
      }
    }
    if (!worker || snapshotName.empty())
      throw std::runtime_error(sceneFile.string() + ": needs one fem solver and one dem unit-cell worker");
    if (worker->size() != 1) throw std::runtime_error(sceneFile.string() + ": the worker must hold exactly one cell");
    const auto h5 = cosim::io::H5File::openReadOnly(findFile(runDir, snapshotName));
    const std::vector<double> X = h5.readArray("/mesh/coordinates");
    if (X.size() != 24) throw std::runtime_error(snapshotName + ": L2 needs one 8-node element, the mesh has " +
                                                 std::to_string(X.size() / 3) + " nodes");
    // The fit equals the one-point F only for a rectangular box (sum dX dX^T diagonal).
    std::array<double, 3> lo{X[0], X[1], X[2]}, hi = lo;
    for (std::size_t p = 0; p < 8; ++p)
      for (std::size_t d = 0; d < 3; ++d) lo[d] = std::min(lo[d], X[3 * p + d]), hi[d] = std::max(hi[d], X[3 * p + d]);
    const double size = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    for (std::size_t p = 0; p < 8; ++p)
      for (std::size_t d = 0; d < 3; ++d)
        if (std::min(std::abs(X[3 * p + d] - lo[d]), std::abs(X[3 * p + d] - hi[d])) > 1e-12 * size)
          throw std::runtime_error(snapshotName + ": L2 needs one rectangular box element (node " + std::to_string(p) +
                                   " is not on a corner of the bounding box)");
    double hourglass = 0.0;
    std::vector<M3> F;
    std::vector<std::vector<double>> gmhVoigt;  // xx yy zz xy yz xz
    for (int n = 0; h5.exists("/snapshots/" + std::to_string(n)); ++n) {
      const std::string g = "/snapshots/" + std::to_string(n);
      double residual = 0.0;
      const std::vector<double> position = h5.readArray(g + "/position"), stress = h5.readArray(g + "/stress");
      if (position.size() != X.size() || stress.size() != 6 || !std::all_of(position.begin(), position.end(), isFinite) ||
          !std::all_of(stress.begin(), stress.end(), isFinite))
        throw std::runtime_error(snapshotName + ": " + g + " needs " + std::to_string(X.size()) +
                                 " finite position values and 6 finite stress values, has " +
                                 std::to_string(position.size()) + " and " + std::to_string(stress.size()));
      F.push_back(fitF(X, position, residual));
      hourglass = std::max(hourglass, residual);
      gmhVoigt.push_back(stress);
    }
    if (F.size() < 3) throw std::runtime_error(snapshotName + ": fewer than 3 snapshots");
    const std::size_t steps = F.size() - 1;  // GMH stresses known at F_0 .. F_{steps-1}

    // Which test: simple shear (F_xz grows) or compression (F_zz shrinks).
    const M3& Fe = F[steps - 1];
    const bool shear = std::abs(Fe[2]) > std::abs(Fe[8] - 1.0);
    const std::array<Component, 2> comps =
        shear ? std::array<Component, 2>{Component{0, 2, "s_xz"}, Component{2, 2, "s_zz"}}
              : std::array<Component, 2>{Component{2, 2, "s_zz"}, Component{0, 0, "s_xx"}};
    auto voigt = [](const std::vector<double>& v, const Component& c) {
      static const int idx[3][3] = {{0, 3, 5}, {3, 1, 4}, {5, 4, 2}};
      return v[static_cast<std::size_t>(idx[c.row][c.col])];
    };

    // The direct DEM test along F_0 .. F_{steps-1}, and a second one from a copy
    // of the cell with every increment scaled by 1 + perturb (1e-10): a dense frictional
    // packing is chaotic near its peak (contacts slip or not on round-off), so
    // two runs whose paths differ in the tenth digit, as GMH's corotational
    // increments (Liu Eqs. 60-61) and these spatial logarithms do, part ways
    // there. RMS(DEM - DEM') is the noise floor the GMH difference is read against.
    const std::uint32_t id = worker->ids().front();
    cosim::dem::DemSystem& cell = worker->cell(id);
    cosim::dem::DemSystem twin = cosim::dem::cloneCell(cell);
    const cosim::dem::RelaxSettings& relax = worker->settings();
    std::vector<M3> dem{cosim::dem::measureCell(cell).stress}, demTwin{dem.front()};
    long demSteps = 0;
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t n = 1; n < steps; ++n) {
      M3 d{};
      if (corotational) {
        // Liu Eqs. 60-61, as fem_solver sends them: D of the increment of the
        // spatial gradient at the midstep F, rotated into the polar frame of F_mid.
        M3 mid{}, dF{};
        for (std::size_t i = 0; i < 9; ++i) mid[i] = 0.5 * (F[n][i] + F[n - 1][i]), dF[i] = F[n][i] - F[n - 1][i];
        const M3 dl = mul(dF, inverse(mid));
        M3 sym{};
        for (std::size_t i = 0; i < 3; ++i)
          for (std::size_t j = 0; j < 3; ++j) sym[3 * i + j] = 0.5 * (dl[3 * i + j] + dl[3 * j + i]);
        const M3 r = polarRotation(mid);
        d = mul(transpose(r), mul(sym, r));
      } else {
        M3 a = mul(F[n], inverse(F[n - 1]));
        for (std::size_t i = 0; i < 3; ++i) a[4 * i] -= 1.0;
        d = logOfIdentityPlus(a);
      }
      const cosim::dem::JobOutcome o = cosim::dem::runUnitCellJob(cell, d, relax);
      if (!o.problem().empty()) throw std::runtime_error("direct DEM step " + std::to_string(n) + ": " + o.problem());
      // Corotational: the cell's stress is sigma^R; the lab stress is R(F_n) sigma^R R^T (Liu Eq. 62).
      const M3 rn = corotational ? polarRotation(F[n]) : M3{1, 0, 0, 0, 1, 0, 0, 0, 1};
      dem.push_back(mul(rn, mul(o.measures.stress, transpose(rn))));
      demSteps += o.steps;
      for (double& v : d) v *= 1.0 + perturb;
      const cosim::dem::JobOutcome t = cosim::dem::runUnitCellJob(twin, d, relax);
      if (!t.problem().empty()) throw std::runtime_error("perturbed DEM step " + std::to_string(n) + ": " + t.problem());
      demTwin.push_back(mul(rn, mul(t.measures.stress, transpose(rn))));
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    std::printf("# L2 %s: %zu steps, %s; direct DEM (%s increments) %ld cell steps, %.1f s; largest non-affine (hourglass) node "
                "displacement %.3g of the element size\n", shear ? "simple shear" : "compression", steps - 1,
                sceneFile.string().c_str(), corotational ? "corotational" : "spatial", demSteps, wall, hourglass / size);
    std::printf("# %-10s %14s %14s %14s %14s   [kPa, tension positive]\n", shear ? "gamma" : "eps_zz",
                (std::string("GMH ") + comps[0].name).c_str(), (std::string("DEM ") + comps[0].name).c_str(),
                (std::string("GMH ") + comps[1].name).c_str(), (std::string("DEM ") + comps[1].name).c_str());
    const std::size_t every = std::max<std::size_t>(1, steps / 15);
    std::array<double, 2> sq{}, sqTwin{}, peak{}, peakChange{};
    for (std::size_t n = 0; n < steps; ++n) {
      const double strain = shear ? F[n][2] : std::log(F[n][8]);
      std::array<double, 2> g{}, d{};
      for (int c = 0; c < 2; ++c) {
        g[c] = voigt(gmhVoigt[n + 1], comps[c]);
        d[c] = dem[n][3 * comps[c].row + comps[c].col];
        sq[c] += (g[c] - d[c]) * (g[c] - d[c]);
        const double dt = demTwin[n][3 * comps[c].row + comps[c].col];
        sqTwin[c] += (dt - d[c]) * (dt - d[c]);
        peak[c] = std::max(peak[c], std::abs(d[c]));
        peakChange[c] = std::max(peakChange[c], std::abs(d[c] - dem[0][3 * comps[c].row + comps[c].col]));
      }
      if (n % every == 0 || n + 1 == steps)
        std::printf("  %-10.5f %14.2f %14.2f %14.2f %14.2f\n", strain, g[0] / 1e3, d[0] / 1e3, g[1] / 1e3, d[1] / 1e3);
    }
    // Up to the peak of the first component (before the chaotic regime).
    std::size_t peakAt = 0;
    for (std::size_t n = 0; n < steps; ++n)
      if (std::abs(dem[n][3 * comps[0].row + comps[0].col]) >= std::abs(dem[peakAt][3 * comps[0].row + comps[0].col]))
        peakAt = n;
    bool pass = true;
    for (int c = 0; c < 2; ++c) {
      double pre = 0.0;
      for (std::size_t n = 0; n <= peakAt; ++n) {
        const double e = voigt(gmhVoigt[n + 1], comps[c]) - dem[n][3 * comps[c].row + comps[c].col];
        pre += e * e;
      }
      std::printf("  up to the peak of %s (step %zu): RMS(GMH - DEM) %s = %.3g %% of peak\n", comps[0].name, peakAt,
                  comps[c].name, 100.0 * std::sqrt(pre / static_cast<double>(peakAt + 1)) / peak[c]);
      const double rms = std::sqrt(sq[c] / static_cast<double>(steps));
      std::printf("RMS(GMH - DEM) %s = %.3g kPa = %.3g %% of peak |%s| (%.1f kPa), %.3g %% of peak change (%.1f kPa)\n",
                  comps[c].name, rms / 1e3, 100.0 * rms / peak[c], comps[c].name, peak[c] / 1e3,
                  100.0 * rms / peakChange[c], peakChange[c] / 1e3);
      std::printf("  noise floor RMS(DEM - DEM with increments x (1 + %.3g)) %s = %.3g kPa = %.3g %% of peak\n",
                  perturb, comps[c].name, std::sqrt(sqTwin[c] / static_cast<double>(steps)) / 1e3,
                  100.0 * std::sqrt(sqTwin[c] / static_cast<double>(steps)) / peak[c]);
      if (maxRms > 0.0 && !(rms / peak[c] <= maxRms)) pass = false;
    }
    if (!pass) {
      std::fprintf(stderr, "l2_compare: RMS difference above %.3g of the peak\n", maxRms);
      return 1;
    }
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "l2_compare: %s\n", ex.what());
    return 2;
  }
  return 0;
}
