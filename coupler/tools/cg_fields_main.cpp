// cg_fields: coarse-grains one DEM snapshot (dem_solver's HDF5 snapshots)
// onto a regular grid and writes density, momentum, velocity, stresses and
// the wall-force density to HDF5 with an XDMF sidecar that ParaView opens as
// a 3D regular grid (3DCoRectMesh). Formulas: cg_fields.hpp, docs/coarse_graining.md.
//
// The shared XdmfTimeSeries describes point sets and meshes with explicit
// geometry; a regular grid needs the ORIGIN_DXDYDZ geometry and a Dimensions
// topology it cannot express, so the sidecar is written here.
#include <hdf5.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cosim/coupler/mapping/cg_fields.hpp"
#include "cosim/io/h5_file.hpp"

namespace {

using namespace cosim::coupler;

constexpr const char* kUsage =
    "usage: cg_fields SNAPSHOT.h5 --kernel lucy|gaussian --width C --spacing H --out FIELDS.h5\n"
    "                 [--step N] [--density RHO] [--normalise analytic|grid] [--branch-points Q]\n"
    "  SNAPSHOT.h5      a dem_solver snapshot file (/snapshots/<step>/...)\n"
    "  --kernel         CG kernel W (Cheng 2022 Eqs. 9-10)\n"
    "  --width          kernel cut-off c [m], > 0\n"
    "  --spacing        grid spacing h [m], 0 < h < c\n"
    "  --out            output HDF5 file; FIELDS.xmf is written beside it\n"
    "  --step           snapshot step (default: the last one)\n"
    "  --density        particle density [kg/m^3] for snapshots without masses\n"
    "  --normalise      analytic (default, Eq. 8 pointwise) or grid (exact grid integrals)\n"
    "  --branch-points  Gauss points along each branch vector (default 4)\n";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Args {
  std::string snapshot, kernel, out;
  double width = 0.0, spacing = 0.0;
  std::optional<std::uint64_t> step;
  std::optional<double> density;
  CgNormalisation normalisation = CgNormalisation::analytic;
  int branchPoints = 4;
};

double positiveNumber(const std::string& arg, const std::string& text) {
  double v = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(v) || v <= 0.0)
    throw UsageError(arg + ": expected a positive number, got '" + text + "'");
  return v;
}

std::uint64_t count(const std::string& arg, const std::string& text) {
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size())
    throw UsageError(arg + ": expected a non-negative integer, got '" + text + "'");
  return v;
}

void applyOption(Args& a, const std::string& arg, const std::string& value) {
  if (arg == "--kernel") {
    if (!CgKernelRegistry::has(value) || CgKernelRegistry::create(value, "CG kernel")->isDirac())
      throw UsageError("--kernel: '" + value + "' is not a kernel with a width (lucy, gaussian)");
    a.kernel = value;
  } else if (arg == "--width") a.width = positiveNumber(arg, value);
  else if (arg == "--spacing") a.spacing = positiveNumber(arg, value);
  else if (arg == "--out") a.out = value;
  else if (arg == "--step") a.step = count(arg, value);
  else if (arg == "--density") a.density = positiveNumber(arg, value);
  else if (arg == "--branch-points") {
    const std::uint64_t q = count(arg, value);
    if (q < 1 || q > 16) throw UsageError("--branch-points: expected 1..16, got '" + value + "'");
    a.branchPoints = static_cast<int>(q);
  } else if (arg == "--normalise") {
    if (value != "analytic" && value != "grid") throw UsageError("--normalise: expected analytic or grid, got '" + value + "'");
    a.normalisation = value == "grid" ? CgNormalisation::grid : CgNormalisation::analytic;
  } else {
    throw UsageError(arg + ": unknown option");
  }
}

Args parseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.rfind("--", 0) != 0) {
      if (!a.snapshot.empty()) throw UsageError(arg + ": a second snapshot file (only one is read)");
      a.snapshot = arg;
      continue;
    }
    if (i + 1 >= argc) throw UsageError(arg + ": missing value");
    applyOption(a, arg, argv[++i]);
  }
  if (a.snapshot.empty()) throw UsageError("SNAPSHOT.h5: missing");
  if (!std::filesystem::is_regular_file(a.snapshot)) throw UsageError("SNAPSHOT.h5: no file '" + a.snapshot + "'");
  if (a.kernel.empty()) throw UsageError("--kernel: missing");
  if (a.width == 0.0) throw UsageError("--width: missing");
  if (a.spacing == 0.0) throw UsageError("--spacing: missing");
  if (a.out.empty()) throw UsageError("--out: missing");
  if (a.spacing >= a.width)
    throw UsageError("--spacing: must be below --width (" + std::to_string(a.width) +
                     "), or the kernel falls between grid points");
  return a;
}

struct Snapshot {
  std::uint64_t step = 0;
  double time = 0.0;
  std::vector<double> positions, velocities, masses, radii;
  std::vector<std::uint32_t> pairFirst, pairSecond, wallParticles;
  std::vector<double> pairPoints, pairForces, wallPoints, wallForces;
};

std::vector<std::uint32_t> indices(const std::vector<double>& v) {
  std::vector<std::uint32_t> out(v.size());
  std::transform(v.begin(), v.end(), out.begin(), [](double x) { return static_cast<std::uint32_t>(x); });
  return out;
}

std::uint64_t chooseStep(const cosim::io::H5File& f, const Args& a) {
  if (a.step) {
    if (!f.exists("/snapshots/" + std::to_string(*a.step)))
      throw UsageError("--step: " + a.snapshot + " has no snapshot " + std::to_string(*a.step));
    return *a.step;
  }
  if (!f.exists("/series/step")) throw UsageError("--step: " + a.snapshot + " lists no steps (/series/step); name one");
  const std::vector<double> steps = f.readArray("/series/step");
  if (steps.empty()) throw UsageError("--step: " + a.snapshot + " holds no snapshot");
  return static_cast<std::uint64_t>(steps.back());
}

void readContacts(const cosim::io::H5File& f, const std::string& g, Snapshot& s) {
  if (!f.exists(g + "/contacts/pairs")) {
    std::cerr << "cg_fields: warning: " << f.path().string() << g
              << " stores no contacts (written before contact output): contact stress and boundary force are zero\n";
    return;
  }
  const std::vector<std::uint32_t> pairs = indices(f.readArray(g + "/contacts/pairs"));
  for (std::size_t k = 0; k + 1 < pairs.size(); k += 2) {
    s.pairFirst.push_back(pairs[k]);
    s.pairSecond.push_back(pairs[k + 1]);
  }
  s.pairPoints = f.readArray(g + "/contacts/pair_points");
  s.pairForces = f.readArray(g + "/contacts/pair_forces");
  s.wallParticles = indices(f.readArray(g + "/contacts/wall_particles"));
  s.wallPoints = f.readArray(g + "/contacts/wall_points");
  s.wallForces = f.readArray(g + "/contacts/wall_forces");
}

/// Throws naming the particle whose value (`per` numbers each) is NaN or infinite.
void requireFinite(const std::vector<double>& values, std::size_t per, const char* what, const std::string& where) {
  for (std::size_t k = 0; k < values.size(); ++k)
    if (!std::isfinite(values[k]))
      throw std::runtime_error(where + ": particle " + std::to_string(k / per) + " has a non-finite " + what);
}

Snapshot readSnapshot(const Args& a) {
  const cosim::io::H5File f = cosim::io::H5File::openReadOnly(a.snapshot);
  Snapshot s;
  s.step = chooseStep(f, a);
  const std::string g = "/snapshots/" + std::to_string(s.step);
  if (f.attribute(g, "periodic", 0.0) != 0.0)
    throw std::runtime_error(a.snapshot + g + ": periodic snapshots are not supported (contact points of periodic "
                                              "images lie a cell away from one partner)");
  s.time = f.attribute(g, "time", 0.0);
  s.positions = f.readArray(g + "/positions");
  s.velocities = f.readArray(g + "/velocities");
  s.radii = f.readArray(g + "/radii");
  if (f.exists(g + "/masses")) {
    s.masses = f.readArray(g + "/masses");
  } else if (a.density) {
    for (double r : s.radii) s.masses.push_back(*a.density * 4.0 / 3.0 * std::numbers::pi * r * r * r);
  } else {
    throw UsageError("--density: " + a.snapshot + g + " stores no masses; give the particle density");
  }
  // A non-finite value would reach the grid's extent and be blamed on --spacing.
  const std::string where = a.snapshot + g;
  requireFinite(s.positions, 3, "position", where);
  requireFinite(s.velocities, 3, "velocity", where);
  requireFinite(s.radii, 1, "radius", where);
  requireFinite(s.masses, 1, "mass", where);
  readContacts(f, g, s);
  return s;
}

// The particles' bounding box grown by the kernel width, so the grid covers every kernel's support.
CgGrid gridAround(const Snapshot& s, double c, double h) {
  std::array<double, 3> lo{}, hi{};
  for (int d = 0; d < 3; ++d) lo[d] = hi[d] = s.positions.empty() ? 0.0 : s.positions[static_cast<std::size_t>(d)];
  for (std::size_t i = 0; i < s.radii.size(); ++i)
    for (std::size_t d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], s.positions[3 * i + d] - s.radii[i]);
      hi[d] = std::max(hi[d], s.positions[3 * i + d] + s.radii[i]);
    }
  CgGrid grid;
  for (int d = 0; d < 3; ++d) {
    grid.origin[d] = lo[d] - c;
    grid.spacing[d] = h;
    grid.counts[d] = static_cast<std::size_t>(std::ceil((hi[d] - lo[d] + 2.0 * c) / h)) + 1;
  }
  if (static_cast<double>(grid.size()) > 2e8)
    throw UsageError("--spacing: " + std::to_string(grid.size()) + " grid points; choose a coarser spacing");
  return grid;
}

// One grid field as an HDF5 dataset nz x ny x nx (x components), the layout the XDMF sidecar names.
void writeGridField(cosim::io::H5File& f, const std::string& path, const CgGrid& g, const std::vector<double>& v,
                    int components) {
  std::vector<hsize_t> dims{g.counts[2], g.counts[1], g.counts[0]};
  if (components > 1) dims.push_back(static_cast<hsize_t>(components));
  f.group(path.substr(0, path.find_last_of('/')));
  const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t d = H5Dcreate2(f.id(), path.c_str(), H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Sclose(space);
  const herr_t status = d < 0 ? -1 : H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
  if (d >= 0) H5Dclose(d);
  if (status < 0) throw std::runtime_error(f.path().string() + ": cannot write " + path);
}

struct FieldSpec {
  const char* name;
  int components;
  const std::vector<double>* values;
};

std::vector<FieldSpec> fieldSpecs(const CgFields& c) {
  return {{"density", 1, &c.density},           {"momentum", 3, &c.momentum},
          {"velocity", 3, &c.velocity},         {"stress", 9, &c.stress},
          {"contact_stress", 9, &c.contactStress}, {"kinetic_stress", 9, &c.kineticStress},
          {"boundary_force", 3, &c.boundaryForce}};
}

void writeXdmf(const std::filesystem::path& h5, const CgGrid& g, const Snapshot& s, const CgFields& c) {
  const std::filesystem::path xmf = std::filesystem::path(h5).replace_extension(".xmf");
  std::ofstream out(xmf);
  out << std::setprecision(17);
  const std::string dims =
      std::to_string(g.counts[2]) + " " + std::to_string(g.counts[1]) + " " + std::to_string(g.counts[0]);
  out << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
      << "  <Grid Name=\"cg_fields\" GridType=\"Collection\" CollectionType=\"Temporal\">\n"
      << "   <Grid Name=\"step " << s.step << "\" GridType=\"Uniform\">\n    <Time Value=\"" << s.time << "\"/>\n"
      << "    <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << dims << "\"/>\n"
      << "    <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"  // XDMF orders both triples z y x
      << "     <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << g.origin[2] << ' '
      << g.origin[1] << ' ' << g.origin[0] << "</DataItem>\n"
      << "     <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << g.spacing[2] << ' '
      << g.spacing[1] << ' ' << g.spacing[0] << "</DataItem>\n    </Geometry>\n";
  for (const FieldSpec& f : fieldSpecs(c)) {
    const char* type = f.components == 1 ? "Scalar" : f.components == 3 ? "Vector" : "Tensor";
    out << "    <Attribute Name=\"" << f.name << "\" AttributeType=\"" << type << "\" Center=\"Node\">"
        << "<DataItem Dimensions=\"" << dims;
    if (f.components > 1) out << ' ' << f.components;
    out << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5.filename().string() << ":/snapshots/"
        << s.step << "/" << f.name << "</DataItem></Attribute>\n";
  }
  out << "   </Grid>\n  </Grid>\n </Domain>\n</Xdmf>\n";
  if (!out) throw std::runtime_error(xmf.string() + ": cannot write the XDMF sidecar");
}

void writeFields(const Args& a, const CgGrid& grid, const Snapshot& s, const CgFields& c) {
  cosim::io::H5File f = cosim::io::H5File::create(a.out);
  const std::string g = "/snapshots/" + std::to_string(s.step);
  f.group(g);
  f.setAttribute(g, "time", s.time);
  f.setAttribute(g, "kernel", a.kernel);
  f.setAttribute(g, "width", a.width);
  f.setAttribute(g, "normalisation", a.normalisation == CgNormalisation::grid ? "grid" : "analytic");
  f.setAttribute(g, "source", a.snapshot);
  for (const FieldSpec& spec : fieldSpecs(c)) writeGridField(f, g + "/" + spec.name, grid, *spec.values, spec.components);
  f.writeArray("/grid/origin", grid.origin);
  f.writeArray("/grid/spacing", grid.spacing);
  const std::array<double, 3> counts{static_cast<double>(grid.counts[0]), static_cast<double>(grid.counts[1]),
                                     static_cast<double>(grid.counts[2])};
  f.writeArray("/grid/counts", counts);
  f.flush();
  writeXdmf(a.out, grid, s, c);
}

int run(const Args& a) {
  const Snapshot s = readSnapshot(a);
  const CgGrid grid = gridAround(s, a.width, a.spacing);
  const auto kernel = CgKernelRegistry::create(a.kernel, "CG kernel");
  const CgParticles particles{s.positions, s.velocities, s.masses, s.radii};
  const CgPairContacts pairs{s.pairFirst, s.pairSecond, s.pairPoints, s.pairForces};
  const CgWallContacts walls{s.wallParticles, s.wallPoints, s.wallForces};
  const CgFields fields = coarseGrain(*kernel, {a.width, a.normalisation, a.branchPoints}, grid, particles, pairs, walls);
  writeFields(a, grid, s, fields);
  double mass = 0.0, gridMass = 0.0;
  for (double m : s.masses) mass += m;
  for (double rho : fields.density) gridMass += rho * grid.cellVolume();
  std::cout << "cg_fields: step " << s.step << ", " << s.masses.size() << " particles, " << s.pairFirst.size()
            << " pair and " << s.wallParticles.size() << " wall contacts -> " << grid.counts[0] << " x "
            << grid.counts[1] << " x " << grid.counts[2] << " grid in " << a.out << "\n"
            << "cg_fields: grid mass " << gridMass << " kg of " << mass << " kg (relative difference "
            << (mass > 0.0 ? std::fabs(gridMass - mass) / mass : 0.0) << ")\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parseArgs(argc, argv));
  } catch (const UsageError& e) {
    std::cerr << "cg_fields: " << e.what() << "\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "cg_fields: " << e.what() << "\n";
    return 1;
  }
}
