// Throughput of dem_solver on the settling scene (configs/dem/settling.yaml):
// monodisperse spheres on a jittered cubic lattice in a box of plane walls,
// Hertz-Mindlin with history, settling under gravity. Prints particle-steps
// per second and the physical end state (kinetic energy, coordination number,
// packing height) so runs of different codes can be checked for the same physics.
//
//   dem_settling_bench [--n 8000|64000] [--steps S] [--settle S0] [--threads T] [--scene FILE]
//                      [--state FILE]   (reuse a settled state: read it if present, else write it)
//                      [--data FILE]    (write the initial state as a LAMMPS data file and stop)
//                      [--phases on]    (also print the timed steps' time per phase, ns per particle-step)
//
// The scene's lattice is resized to n = side^3 spheres (the box grows with it);
// --settle runs S0 untimed steps first so the timed steps see a dense packing.
// --data hands the same jittered lattice to LAMMPS and LIGGGHTS (read_data,
// atom_style sphere), so bench/peers/dem_settling_compare.sh times all three
// codes from identical positions.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cosim/dem/io/checkpoint.hpp"
#include "cosim/dem/measure/measures.hpp"
#include "cosim/dem/solver/scene_params.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace cosim::dem;

// Process CPU time: on a shared machine, wall time alone mixes in other load.
static double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// The initial state as a LAMMPS data file (atom_style sphere: id type diameter
// density x y z), box [0, box]^2 in x and y and from the floor to twice the
// highest sphere top in z, so nothing leaves a fixed box. All spheres are of
// material 0, at rest.
static void writeLammpsData(const DemSystem& s, double box, const std::string& file) {
  const Particles& p = s.particles;
  double top = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) top = std::max(top, p.x[i].z + p.radius[i]);
  std::FILE* out = std::fopen(file.c_str(), "w");
  if (!out) throw std::runtime_error("cannot write " + file);
  std::fprintf(out, "settling scene from dem_settling_bench\n\n%zu atoms\n1 atom types\n\n", p.size());
  std::fprintf(out, "0 %.17g xlo xhi\n0 %.17g ylo yhi\n0 %.17g zlo zhi\n\nAtoms # sphere\n\n", box, box, 2.0 * top);
  const double density = s.materials[0].density;
  for (std::size_t i = 0; i < p.size(); ++i)
    std::fprintf(out, "%zu 1 %.17g %.17g %.17g %.17g %.17g\n", i + 1, 2.0 * p.radius[i], density, p.x[i].x, p.x[i].y,
                 p.x[i].z);
  std::fclose(out);
}

int main(int argc, char** argv) {
  long n = 8000, steps = 2000, settle = 0;
  int threads = 0;
  bool phases = false;
  std::string scene = COSIM_DEM_CONFIG_DIR "/settling.yaml", state, data;
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string k = argv[a], v = argv[a + 1];
    if (k == "--n") n = std::stol(v);
    else if (k == "--steps") steps = std::stol(v);
    else if (k == "--settle") settle = std::stol(v);
    else if (k == "--threads") threads = std::stoi(v);
    else if (k == "--scene") scene = v;
    else if (k == "--state") state = v;
    else if (k == "--data") data = v;
    else if (k == "--phases" && (v == "on" || v == "off")) phases = v == "on";
    else {
      std::fprintf(stderr, "unknown option or value: %s %s\n", k.c_str(), v.c_str());
      return 2;
    }
  }
#ifdef _OPENMP
  if (threads > 0) omp_set_num_threads(threads);
  threads = omp_get_max_threads();
#else
  threads = 1;
#endif
  std::ifstream in(scene);
  std::stringstream text;
  text << in.rdbuf();
  YAML::Node root = YAML::Load(text.str());
  YAML::Node params = root["solvers"][0]["params"];
  const double schedDt = root["schedule"]["dt"].as<double>();
  // Resize the lattice and the box to n = side^3 spheres.
  const int side = static_cast<int>(std::lround(std::cbrt(static_cast<double>(n))));
  YAML::Node lattice = params["particles"][0]["lattice"];
  const double spacing = lattice["spacing"].as<double>();
  lattice["counts"] = std::vector<int>{side, side, side};
  const double box = spacing * side;
  for (auto w : params["walls"]) {
    const std::string name = w["name"].as<std::string>();
    if (name == "x+") w["point"] = std::vector<double>{box, 0, 0};
    if (name == "y+") w["point"] = std::vector<double>{0, box, 0};
  }
  params.remove("snapshots");
  DemSystem s;
  RunSettings settings;
  configure(params, scene, s, settings);
  s.initialize();
  const double dt = schedDt;
  if (!data.empty()) {
    writeLammpsData(s, box, data);
    // What the peers' damping inputs are mapped from (bench/peers/dem_settling_compare.sh).
    const PairMaterial& pm = s.materials.pair(0, 0);
    std::printf("pair: E* %.17g G* %.17g gamma %.17g restitution %.17g friction %.17g\n", pm.eEff, pm.gEff, pm.gamma,
                pm.restitution, pm.friction);
    return 0;
  }
  std::printf("settling: N = %zu, dt = %.3g s, critical %.3g s, threads %d, law %s\n", s.particles.size(), dt,
              criticalTimeStep(s), threads, s.contactLaw().name().c_str());
  if (!state.empty() && std::ifstream(state).good()) {
    readCheckpoint(s, state);
    std::printf("settled state read from %s (t = %.4f s)\n", state.c_str(), s.time);
  } else {
    for (long k = 0; k < settle; ++k) s.advance(dt);
    if (!state.empty()) writeCheckpoint(s, state);
  }
  const auto builds0 = s.neighbors.builds;
  const double cpu0 = cpuSeconds();
  const auto t0 = std::chrono::steady_clock::now();
  s.timing = phases;
  for (long k = 0; k < steps; ++k) s.advance(dt);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = cpuSeconds() - cpu0;
  const double rate = static_cast<double>(s.particles.size()) * static_cast<double>(steps) / wall;
  double top = 0.0;
  for (std::size_t i = 0; i < s.particles.size(); ++i) top = std::max(top, s.particles.x[i].z + s.particles.radius[i]);
  const Energies e = energies(s);
  std::printf("steps %ld in %.3f s wall (%.3f s CPU): %.3f M particle-steps/s wall, %.3f M per CPU-second\n", steps,
              wall, cpu, rate * 1e-6, static_cast<double>(s.particles.size()) * static_cast<double>(steps) / cpu * 1e-6);
  std::printf("end state: t = %.4f s, kinetic %.6e J, coordination %.3f, packing height %.5f m, "
              "neighbour pairs %zu, rebuilds %llu\n",
              s.time, e.kinetic(), coordinationNumber(s), top, s.neighbors.pairs(),
              static_cast<unsigned long long>(s.neighbors.builds - builds0));
  if (phases) {
    const DemSystem::PhaseTimes& t = s.phaseTimes;
    const double ns = 1e9 / static_cast<double>(t.particleSteps);
    std::printf("phases [ns per particle-step]: open %.2f, neighbours %.2f, pairs %.2f, gather %.2f, close %.2f\n",
                t.open * ns, t.neighbors * ns, t.pairs * ns, t.gather * ns, t.close * ns);
  }
  return 0;
}
