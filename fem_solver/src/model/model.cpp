#include "cosim/fem/model/model.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <exception>
#include <sstream>

#include "cosim/fem/fem/hex8.hpp"
#include "cosim/fem/linalg/dof_loop.hpp"
#include "cosim/fem/linalg/sparse_system.hpp"

namespace cosim::fem {

// Below this many elements a parallel region costs more than it saves
// (and on an oversubscribed machine a barrier can cost milliseconds).
constexpr long kParallelElements = 2000;
// Elements per block of the coloured element loops: large enough that the
// elements of a block reuse each other's nodes in cache, small enough that a
// colour holds many blocks to share between threads.
constexpr std::size_t kBlockElements = 128;

namespace {
/// Exceptions must not leave an OpenMP region: keep the first, rethrow after.
class ExceptionCollector {
 public:
  template <class F>
  bool run(F&& f) {
    try {
      f();
      return true;
    } catch (...) {
#pragma omp critical(cosim_fem_exception)
      if (!first_) first_ = std::current_exception();
      return false;
    }
  }
  void rethrow() const {
    if (first_) std::rethrow_exception(first_);
  }

 private:
  std::exception_ptr first_;
};

/// Sums block energies in block order (thread-count independent).
void addEnergies(const std::vector<ElementEnergy>& parts, ElementEnergy& total) {
  for (const ElementEnergy& en : parts) {
    total.strain += en.strain;
    total.hourglass += en.hourglass;
  }
}
}  // namespace

double Prescribed::displacement(double t) const {
  if (frequency > 0.0) {
    const double omega = 2.0 * std::numbers::pi * frequency;
    return kind == Kind::velocity ? amplitude * (1.0 - std::cos(omega * t)) / omega : amplitude * std::sin(omega * t);
  }
  if (kind == Kind::velocity) return amplitude * t;
  return ramp > 0.0 ? amplitude * std::min(t / ramp, 1.0) : amplitude;
}

double Prescribed::velocity(double t) const {
  if (frequency > 0.0) {
    const double omega = 2.0 * std::numbers::pi * frequency;
    return kind == Kind::velocity ? amplitude * std::sin(omega * t) : amplitude * omega * std::cos(omega * t);
  }
  if (kind == Kind::velocity) return amplitude;
  return (ramp > 0.0 && t < ramp) ? amplitude / ramp : 0.0;
}

Model::Model(Mesh mesh, std::unique_ptr<Material> material, std::unique_ptr<ElementFormulation> formulation,
             const FormulationOptions& options)
    : mesh_(std::move(mesh)),
      material_(std::move(material)),
      formulation_(std::move(formulation)) {
  // Parallelism lives in the element loop. Eigen would otherwise fork OpenMP
  // threads inside every element's 33 x 33 product: measured on the 2 x 30 x 2
  // cantilever, 38 ms per Newmark step with that, 14 ms without.
  Eigen::setNbThreads(1);
  mesh_.validate();
  formulation_->initialise(mesh_, *material_, options);
  material_->setPointCount(mesh_.numElements() * static_cast<std::size_t>(formulation_->pointsPerElement()));
  fixed_.assign(numDofs(), 0);
  referenceLoad_.assign(numDofs(), 0.0);
  couplingForce_.assign(numDofs(), 0.0);
  dofMap_.resize(numDofs());
  for (std::size_t d = 0; d < numDofs(); ++d) dofMap_[d] = static_cast<int>(d);
  numFree_ = static_cast<int>(numDofs());
  computeMass();
  colourElementBlocks();
}

double Model::massWeight(std::size_t e, int q) const {
  return gaussWeight_.empty() ? 1.0 : gaussWeight_[8 * e + static_cast<std::size_t>(q)];
}

const double* Model::gaussScale(std::size_t e) const {
  static const double kOnes[8] = {1, 1, 1, 1, 1, 1, 1, 1};
  return gaussWeight_.empty() ? kOnes : gaussWeight_.data() + 8 * e;
}

void Model::computeMass() {
  // Row-sum lumped mass m_a = int (1 - w) rho N_a dV (2x2x2 Gauss).
  hex8::ReferenceGeometry geometry;
  geometry.build(mesh_);
  unscaledLumpedMass_.assign(numNodes(), 0.0);
  for (std::size_t e = 0; e < mesh_.numElements(); ++e)
    for (int q = 0; q < 8; ++q) {
      const hex8::Shape N = hex8::shape(hex8::gaussPoint(q));
      for (int a = 0; a < 8; ++a)
        unscaledLumpedMass_[mesh_.elements[e][static_cast<std::size_t>(a)]] +=
            material_->density() * N(a) * geometry.weight(e, q) * massWeight(e, q);
    }
  lumpedMass_ = unscaledLumpedMass_;
  for (double& m : lumpedMass_) m *= massScale_;
}

Vec3 Model::materialPoint(std::size_t e, int q) const {
  const Vec3 xi = formulation_->pointsPerElement() == 1 ? Vec3::Zero() : hex8::gaussPoint(q);
  return mesh_.elementCoordinates(e).transpose() * hex8::shape(xi);
}

void Model::setArlequinWeight(const WeightProfile& profile) {
  if (const std::string why = profile.problem(); !why.empty()) throw InputError("weight profile: " + why);
  const std::size_t ne = mesh_.numElements();
  elementMass_.clear();
  gaussWeight_.assign(8 * ne, 1.0);
  const int np = formulation_->pointsPerElement();
  std::vector<double> pointScale(ne * static_cast<std::size_t>(np));
  // 1 - w at a point of element e: w evaluated there (Cheng 2022 Eq. 25), or
  // the nodes' w interpolated with the shape functions (the published runs).
  const auto fe = [&](std::size_t e, const Vec3& xi) {
    const Mat83 X = mesh_.elementCoordinates(e);
    const hex8::Shape N = hex8::shape(xi);
    if (!profile.nodalFem) return 1.0 - profile(Vec3(X.transpose() * N));
    double w = 0.0;
    for (int a = 0; a < 8; ++a) w += N(a) * profile(Vec3(X.row(a).transpose()));
    return 1.0 - w;
  };
  for (std::size_t e = 0; e < ne; ++e) {
    for (int q = 0; q < 8; ++q) gaussWeight_[8 * e + static_cast<std::size_t>(q)] = fe(e, hex8::gaussPoint(q));
    for (int q = 0; q < np; ++q)
      pointScale[e * static_cast<std::size_t>(np) + static_cast<std::size_t>(q)] =
          fe(e, np == 1 ? Vec3::Zero().eval() : hex8::gaussPoint(q));
  }
  formulation_->setPointScale(std::move(pointScale));
  // Body forces were integrated with the unweighted mass: redo them.
  std::vector<double> oldMass = unscaledLumpedMass_;
  computeMass();
  for (std::size_t n = 0; n < numNodes(); ++n) {
    if (!(unscaledLumpedMass_[n] > 0.0))
      throw InputError("node " + std::to_string(n) + " has no mass after Arlequin weighting (1 - w = 0 around it)");
    if (!bodyAcceleration_.empty())
      for (std::size_t i = 0; i < 3; ++i)
        referenceLoad_[3 * n + i] += (unscaledLumpedMass_[n] - oldMass[n]) * bodyAcceleration_[i];
  }
}

void Model::colourElementBlocks() {
  const std::size_t ne = mesh_.numElements();
  const std::size_t nb = (ne + kBlockElements - 1) / kBlockElements;
  // Blocks touching each node (CSR, repeats allowed).
  std::vector<std::size_t> start(numNodes() + 1, 0), blocks(8 * ne);
  for (const Hex& h : mesh_.elements)
    for (Index n : h) ++start[n + 1];
  for (std::size_t n = 0; n < numNodes(); ++n) start[n + 1] += start[n];
  std::vector<std::size_t> cursor(start.begin(), start.end() - 1);
  for (std::size_t e = 0; e < ne; ++e)
    for (Index n : mesh_.elements[e]) blocks[cursor[n]++] = e / kBlockElements;
  // Greedy: each block takes the lowest colour none of its neighbours holds.
  std::vector<std::size_t> colour(nb), takenBy;  // takenBy[c] = b + 1: a neighbour of b holds c
  std::size_t colours = 0;
  for (std::size_t b = 0; b < nb; ++b) {
    for (std::size_t e = b * kBlockElements; e < std::min(ne, (b + 1) * kBlockElements); ++e)
      for (Index n : mesh_.elements[e])
        for (std::size_t k = start[n]; k < start[n + 1]; ++k)
          if (blocks[k] < b) takenBy[colour[blocks[k]]] = b + 1;
    std::size_t c = 0;
    while (c < colours && takenBy[c] == b + 1) ++c;
    if (c == colours) {
      ++colours;
      takenBy.push_back(0);
    }
    colour[b] = c;
  }
  colourStart_.assign(colours + 1, 0);
  for (std::size_t b = 0; b < nb; ++b) ++colourStart_[colour[b] + 1];
  for (std::size_t c = 0; c < colours; ++c) colourStart_[c + 1] += colourStart_[c];
  colourBlocks_.resize(nb);
  std::vector<std::size_t> next(colourStart_.begin(), colourStart_.end() - 1);
  for (std::size_t b = 0; b < nb; ++b) colourBlocks_[next[colour[b]]++] = b;
  blockEnergy_.assign(nb, ElementEnergy{});
}

template <class Kernel>
void Model::forEachElementBlock(bool parallel, Kernel&& kernel) const {
  const std::size_t ne = mesh_.numElements();
  ExceptionCollector errors;
#pragma omp parallel if (parallel && static_cast<long>(ne) > kParallelElements)
  for (std::size_t c = 0; c + 1 < colourStart_.size(); ++c) {
    const long begin = static_cast<long>(colourStart_[c]), end = static_cast<long>(colourStart_[c + 1]);
#pragma omp for schedule(dynamic)
    for (long k = begin; k < end; ++k) {
      const std::size_t b = colourBlocks_[static_cast<std::size_t>(k)];
      errors.run([&] { kernel(b, b * kBlockElements, std::min(ne, (b + 1) * kBlockElements)); });
    }
  }
  errors.rethrow();
}

void Model::scatter(std::size_t e, const Vec24& fe, std::vector<double>& f) const {
  const Hex& h = mesh_.elements[e];
  for (int a = 0; a < 8; ++a)
    for (int i = 0; i < 3; ++i) f[3 * h[static_cast<std::size_t>(a)] + static_cast<std::size_t>(i)] += fe(3 * a + i);
}

void Model::prescribe(Index node, int direction, Prescribed::Kind kind, double amplitude, double ramp,
                      double frequency) {
  if (node >= numNodes() || direction < 0 || direction > 2)
    throw InputError("prescribed dof out of range: node " + std::to_string(node));
  if (!std::isfinite(amplitude)) throw InputError("prescribed value for node " + std::to_string(node) + " is not finite");
  if (!std::isfinite(frequency) || frequency < 0.0)
    throw InputError("prescribed frequency for node " + std::to_string(node) + " must be finite and >= 0");
  const std::size_t dof = 3 * node + static_cast<std::size_t>(direction);
  Prescribed p{dof, kind, amplitude, ramp, frequency};
  if (fixed_[dof]) {
    for (auto& q : prescribed_)
      if (q.dof == dof) q = p;
  } else {
    fixed_[dof] = 1;
    prescribed_.push_back(p);
  }
  dofMapStale_ = true;
}

namespace {
/// A jump amplitude with its time function; sums need one time function
/// (a zero amplitude goes with any).
struct Jump {
  double amplitude = 0.0;
  Prescribed::Kind kind = Prescribed::Kind::displacement;
  double ramp = 0.0;
  bool compatible(const Jump& o) const {
    return amplitude == 0.0 || o.amplitude == 0.0 || (kind == o.kind && ramp == o.ramp);
  }
  Jump plus(const Jump& o, double sign) const {
    Jump r = amplitude == 0.0 ? o : *this;
    r.amplitude = amplitude + sign * o.amplitude;
    return r;
  }
};
}  // namespace

void Model::tie(const std::vector<std::pair<Index, Index>>& pairs, const Vec3& jump, Prescribed::Kind kind,
                double ramp) {
  if (!jump.allFinite()) throw InputError("periodic jump is not finite");
  for (const auto& [slave, master] : pairs) {
    if (slave >= numNodes() || master >= numNodes() || slave == master)
      throw InputError("periodic tie between nodes " + std::to_string(slave) + " and " + std::to_string(master) +
                       " is out of range or ties a node to itself");
    ties_.push_back({slave, master, jump, kind, ramp});
  }
  rebuildDofMap();
}

void Model::rebuildDofMap() const {
  // Union-find with offsets: u[d] = u[parent[d]] + offset[d]. Each tie
  // u_s = u_m + j joins the two trees; the root of a tree is its independent
  // dof, a prescribed one where the tree holds one.
  const std::size_t nd = numDofs();
  std::vector<std::size_t> parent(nd);
  std::vector<Jump> offset(nd);
  for (std::size_t d = 0; d < nd; ++d) parent[d] = d;
  auto find = [&](std::size_t d, Jump& total) {
    total = Jump{};
    while (parent[d] != d) {
      total = total.plus(offset[d], 1.0);
      d = parent[d];
    }
    return d;
  };
  for (const Tie& t : ties_)
    for (std::size_t i = 0; i < 3; ++i) {
      const Jump j{t.jump[static_cast<int>(i)], t.kind, t.ramp};
      Jump js, jm;
      const std::size_t rs = find(3 * t.slave + i, js), rm = find(3 * t.master + i, jm);
      const std::string where = "periodic tie of node " + std::to_string(t.slave) + " to node " +
                                std::to_string(t.master) + " direction " + "xyz"[i];
      // u_rs + js = u_rm + jm + j
      const Jump rel = jm.plus(j, 1.0);
      if (!rel.compatible(js)) throw InputError(where + ": jumps with different ramps or kinds meet here");
      const Jump diff = rel.plus(js, -1.0);  // u_rs = u_rm + diff
      if (rs == rm) {
        if (std::abs(diff.amplitude) > 1e-12 * (std::abs(js.amplitude) + std::abs(rel.amplitude)) + 1e-300)
          throw InputError(where + ": closes a loop with a net jump of " + std::to_string(diff.amplitude));
        continue;
      }
      if (fixed_[rs] && fixed_[rm]) continue;  // both prescribed: the prescriptions win
      if (fixed_[rs]) {
        parent[rm] = rs;
        offset[rm] = Jump{}.plus(diff, -1.0);
      } else {
        parent[rs] = rm;
        offset[rs] = diff;
      }
    }
  slaves_.clear();
  std::vector<std::size_t> root(nd);
  for (std::size_t d = 0; d < nd; ++d) {
    Jump total;
    root[d] = find(d, total);
    if (root[d] != d) slaves_.push_back({d, root[d], Prescribed{d, total.kind, total.amplitude, total.ramp, 0.0}});
  }
  int next = 0;
  for (std::size_t d = 0; d < nd; ++d)
    if (root[d] == d) dofMap_[d] = fixed_[d] ? -1 : next++;
  for (const SlaveDof& s : slaves_) dofMap_[s.dof] = dofMap_[s.master];
  numFree_ = next;
  dofMapStale_ = false;
}

void Model::enforceSlaves(double t, std::vector<double>& u, std::vector<double>* v) const {
  refreshDofMap();
  for (const SlaveDof& s : slaves_) {
    u[s.dof] = u[s.master] + s.jump.displacement(t);
    if (v) (*v)[s.dof] = (*v)[s.master] + s.jump.velocity(t);
  }
}

void Model::applyConstraints(double t, std::vector<double>& u, std::vector<double>* v) const {
  for (const Prescribed& p : prescribed_) {
    u[p.dof] = p.displacement(t);
    if (v) (*v)[p.dof] = p.velocity(t);
  }
  enforceSlaves(t, u, v);
}

void Model::reduce(const std::vector<double>& full, Eigen::VectorXd& reduced) const {
  refreshDofMap();
  reduced.setZero(numFree_);
  for (std::size_t d = 0; d < dofMap_.size(); ++d)
    if (dofMap_[d] >= 0) reduced(dofMap_[d]) += full[d];
}

std::vector<double> Model::constrainedLumpedMass() const {
  refreshDofMap();
  std::vector<double> m(numDofs());
  for (std::size_t d = 0; d < m.size(); ++d) m[d] = lumpedMass_[d / 3];
  for (const SlaveDof& s : slaves_) {
    m[s.master] += m[s.dof];
    m[s.dof] = 0.0;
  }
  return m;
}

double Model::constrainedAcceleration(const std::vector<double>& r, std::vector<double>& a) const {
  refreshDofMap();
  a.resize(r.size());
  if (slaves_.empty()) {  // every explicit step: no copies of r and m
    return sumOverDofs(r.size(), [&](std::size_t d) {
      const double m = lumpedMass_[d / 3];
      const bool free = dofMap_[d] >= 0 && m != 0.0;
      a[d] = free ? r[d] / m : 0.0;
      return free ? r[d] * r[d] : 0.0;
    });
  }
  std::vector<double>& rs = reducedForce_;
  rs = r;
  std::vector<double> m = constrainedLumpedMass();
  for (const SlaveDof& s : slaves_) rs[s.master] += rs[s.dof];
  double r2 = 0.0;
  for (std::size_t d = 0; d < r.size(); ++d) {
    if (dofMap_[d] < 0 || m[d] == 0.0) {
      a[d] = 0.0;
      continue;
    }
    a[d] = rs[d] / m[d];
    r2 += rs[d] * rs[d];
  }
  for (const SlaveDof& s : slaves_) a[s.dof] = a[s.master];
  return r2;
}

void Model::addTieReactions(const std::vector<double>& res, std::vector<double>& fApplied) const {
  refreshDofMap();
  for (const SlaveDof& s : slaves_) {
    if (dofMap_[s.dof] < 0) continue;  // prescribed master: the caller's reaction covers it
    fApplied[s.dof] += res[s.dof];
    fApplied[s.master] -= res[s.dof];
  }
}

void Model::addTraction(const std::vector<Quad>& faces, const Vec3& traction) {
  // int N_a t dA over bilinear quads with 2x2 Gauss points.
  const double g = 1.0 / std::sqrt(3.0);
  const double pts[4][2] = {{-g, -g}, {g, -g}, {g, g}, {-g, g}};
  for (const Quad& q : faces) {
    Eigen::Matrix<double, 4, 3> X;
    for (int a = 0; a < 4; ++a) X.row(a) = mesh_.node(q[static_cast<std::size_t>(a)]).transpose();
    for (const auto& p : pts) {
      const double s = p[0], t = p[1];
      const double N[4] = {0.25 * (1 - s) * (1 - t), 0.25 * (1 + s) * (1 - t), 0.25 * (1 + s) * (1 + t),
                           0.25 * (1 - s) * (1 + t)};
      const Vec3 dS = 0.25 * (-(1 - t) * X.row(0) + (1 - t) * X.row(1) + (1 + t) * X.row(2) - (1 + t) * X.row(3)).transpose();
      const Vec3 dT = 0.25 * (-(1 - s) * X.row(0) - (1 + s) * X.row(1) + (1 + s) * X.row(2) + (1 - s) * X.row(3)).transpose();
      const double dA = dS.cross(dT).norm();
      for (int a = 0; a < 4; ++a)
        for (int i = 0; i < 3; ++i) referenceLoad_[3 * q[static_cast<std::size_t>(a)] + static_cast<std::size_t>(i)] += N[a] * traction[i] * dA;
    }
  }
}

void Model::addPressure(const std::vector<Quad>& faces, double pressure) {
  if (!std::isfinite(pressure)) throw InputError("pressure must be finite");
  pressures_.emplace_back(faces, pressure);
}

void Model::addFollowerLoads(double t, const std::vector<double>& u, std::vector<double>& f) const {
  // f_a = -p int N_a n da on the current face: with x(s, t) bilinear,
  // n da = (dx/ds x dx/dt) ds dt (2x2 Gauss).
  const double factor = loadRamp_ > 0.0 ? std::min(t / loadRamp_, 1.0) : 1.0;
  const double g = 1.0 / std::sqrt(3.0);
  const double pts[4][2] = {{-g, -g}, {g, -g}, {g, g}, {-g, g}};
  for (const auto& [faces, p] : pressures_) {
    for (const Quad& q : faces) {
      Eigen::Matrix<double, 4, 3> x;
      for (int a = 0; a < 4; ++a)
        for (int i = 0; i < 3; ++i) {
          const std::size_t d = 3 * q[static_cast<std::size_t>(a)] + static_cast<std::size_t>(i);
          x(a, i) = mesh_.X[d] + u[d];
        }
      for (const auto& pt : pts) {
        const double s = pt[0], r = pt[1];
        const double N[4] = {0.25 * (1 - s) * (1 - r), 0.25 * (1 + s) * (1 - r), 0.25 * (1 + s) * (1 + r),
                             0.25 * (1 - s) * (1 + r)};
        const Vec3 dS = 0.25 * (-(1 - r) * x.row(0) + (1 - r) * x.row(1) + (1 + r) * x.row(2) - (1 + r) * x.row(3)).transpose();
        const Vec3 dT = 0.25 * (-(1 - s) * x.row(0) - (1 + s) * x.row(1) + (1 + s) * x.row(2) + (1 - s) * x.row(3)).transpose();
        const Vec3 nda = dS.cross(dT);  // outward for outward-ordered faces
        for (int a = 0; a < 4; ++a)
          for (int i = 0; i < 3; ++i)
            f[3 * q[static_cast<std::size_t>(a)] + static_cast<std::size_t>(i)] -= factor * p * N[a] * nda[i];
      }
    }
  }
}

void Model::addBodyForce(const Vec3& acceleration) {
  if (bodyAcceleration_.empty()) bodyAcceleration_.assign(3, 0.0);
  for (int i = 0; i < 3; ++i) bodyAcceleration_[static_cast<std::size_t>(i)] += acceleration[i];
  for (std::size_t n = 0; n < numNodes(); ++n)
    for (int i = 0; i < 3; ++i) referenceLoad_[3 * n + static_cast<std::size_t>(i)] += unscaledLumpedMass_[n] * acceleration[i];
}

void Model::externalForce(double t, std::vector<double>& f) const {
  const double factor = loadRamp_ > 0.0 ? std::min(t / loadRamp_, 1.0) : 1.0;
  f.resize(numDofs());
  forEachDof(numDofs(), [&](std::size_t d) { f[d] = factor * referenceLoad_[d] + couplingForce_[d]; });
}

Mat83 Model::gather(std::size_t e, const std::vector<double>& u) const {
  Mat83 ue;
  const Hex& h = mesh_.elements[e];
  for (int a = 0; a < 8; ++a)
    for (int i = 0; i < 3; ++i) ue(a, i) = u[3 * h[static_cast<std::size_t>(a)] + static_cast<std::size_t>(i)];
  return ue;
}

void Model::internalForce(const std::vector<double>& u, std::vector<double>& f, ElementEnergy& energy) const {
  const ElementFormulation& form = *formulation_;
  f.assign(numDofs(), 0.0);
  forEachElementBlock(true, [&](std::size_t b, std::size_t first, std::size_t last) {
    ElementEnergy sum;
    Vec24 fe;
    for (std::size_t e = first; e < last; ++e) {
      form.evaluate(e, gather(e, u), fe, nullptr, sum);
      scatter(e, fe, f);
    }
    blockEnergy_[b] = sum;
  });
  addEnergies(blockEnergy_, energy);
}

bool Model::viscousForce(const std::vector<double>& v, std::vector<double>& f) const {
  f.assign(numDofs(), 0.0);
  if (!formulation_->hasViscousForce()) return false;
  forEachElementBlock(true, [&](std::size_t, std::size_t first, std::size_t last) {
    Vec24 fe;
    for (std::size_t e = first; e < last; ++e) {
      formulation_->viscousForce(e, gather(e, v), fe);
      scatter(e, fe, f);
    }
  });
  return true;
}

void Model::assembleTangent(const std::vector<double>& u, SparseSystem& K, std::vector<double>& f,
                            ElementEnergy& energy) const {
  assemble(u, false, K, f, energy);
}

void Model::assembleLinearStiffness(const std::vector<double>& u, SparseSystem& K, std::vector<double>& f,
                                    ElementEnergy& energy) const {
  assemble(u, true, K, f, energy);
}

void Model::assemble(const std::vector<double>& u, bool linear, SparseSystem& K, std::vector<double>& f,
                     ElementEnergy& energy) const {
  K.setZero();
  f.assign(numDofs(), 0.0);
  // Blocks of one colour share no node, hence no matrix entry, unless a
  // periodic tie maps dofs of different nodes onto one row: then serially,
  // in the same order.
  forEachElementBlock(slaves().empty(), [&](std::size_t b, std::size_t first, std::size_t last) {
    ElementEnergy sum;
    Vec24 fe;
    Mat24 Ke;
    for (std::size_t e = first; e < last; ++e) {
      const Mat83 ue = gather(e, u);
      if (linear) {  // K_0 at the reference configuration, f = K_0 u, W = u.f / 2
        formulation_->evaluate(e, Mat83::Zero(), fe, &Ke, sum);
        const Eigen::Matrix<double, 8, 3, Eigen::RowMajor> nodeMajor = ue;
        fe.noalias() = Ke * Eigen::Map<const Vec24>(nodeMajor.data());
        sum.strain += 0.5 * fe.dot(Eigen::Map<const Vec24>(nodeMajor.data()));
      } else {
        formulation_->evaluate(e, ue, fe, &Ke, sum);
      }
      K.add(e, Ke);
      scatter(e, fe, f);
    }
    blockEnergy_[b] = sum;
  });
  addEnergies(blockEnergy_, energy);
}

namespace {
// Consistent element mass rho int N_a N_b dV (8 x 8, one block per direction).
Eigen::Matrix<double, 8, 8> elementMass(const Mat83& X, double rho, const double* scale) {
  Eigen::Matrix<double, 8, 8> M = Eigen::Matrix<double, 8, 8>::Zero();
  for (int q = 0; q < 8; ++q) {
    const Vec3 xi = hex8::gaussPoint(q);
    const hex8::Shape N = hex8::shape(xi);
    const double detJ = (X.transpose() * hex8::shapeDerivatives(xi)).determinant();
    M += rho * detJ * scale[q] * N * N.transpose();
  }
  return M;
}
}  // namespace

void Model::assembleMass(SparseSystem& M) const {
  M.setZero();
  for (std::size_t e = 0; e < mesh_.numElements(); ++e) {
    const Eigen::Matrix<double, 8, 8>& m = elementMassMatrix(e);
    Mat24 Me = Mat24::Zero();
    for (int a = 0; a < 8; ++a)
      for (int b = 0; b < 8; ++b)
        for (int i = 0; i < 3; ++i) Me(3 * a + i, 3 * b + i) = m(a, b);
    M.add(e, Me);
  }
}

SparseSystem Model::shiftedStiffness(double massFactor) const {
  SparseSystem K, M;
  K.build(mesh_, dofMap(), numFree());
  M.build(mesh_, dofMap(), numFree());
  std::vector<double> f;
  ElementEnergy energy;
  assembleTangent(std::vector<double>(numDofs(), 0.0), K, f, energy);
  assembleMass(M);
  K.matrix() += massFactor * M.matrix();
  return K;
}

void Model::massTimes(const std::vector<double>& x, std::vector<double>& y, bool lumped) const {
  y.assign(numDofs(), 0.0);
  if (lumped) {
    for (std::size_t d = 0; d < numDofs(); ++d) y[d] = lumpedMass_[d / 3] * x[d];
    return;
  }
  for (std::size_t e = 0; e < mesh_.numElements(); ++e) {
    const Eigen::Matrix<double, 8, 8>& m = elementMassMatrix(e);
    const Mat83 xe = gather(e, x);
    const Mat83 ye = m * xe;
    const Hex& h = mesh_.elements[e];
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i) y[3 * h[static_cast<std::size_t>(a)] + static_cast<std::size_t>(i)] += ye(a, i);
  }
}

double Model::kineticEnergy(const std::vector<double>& v, bool lumped) const {
  std::vector<double> mv;
  massTimes(v, mv, lumped);
  double k = 0.0;
  for (std::size_t d = 0; d < numDofs(); ++d) k += 0.5 * v[d] * mv[d];
  return k;
}

const Eigen::Matrix<double, 8, 8>& Model::elementMassMatrix(std::size_t e) const {
  if (elementMass_.size() != mesh_.numElements()) {
    elementMass_.resize(mesh_.numElements());
    for (std::size_t k = 0; k < elementMass_.size(); ++k)
      elementMass_[k] = massScale_ * elementMass(mesh_.elementCoordinates(k), material_->density(), gaussScale(k));
  }
  return elementMass_[e];
}

void Model::setMassScale(double s) {
  if (!(s > 0.0) || !std::isfinite(s)) throw InputError("mass scaling factor must be positive");
  massScale_ = s;
  elementMass_.clear();
  for (std::size_t n = 0; n < numNodes(); ++n) lumpedMass_[n] = s * unscaledLumpedMass_[n];
}

double Model::criticalTimeStep(double dampingAlpha) const {
  // omega_max <= max_e omega_e for a lumped mass (Irons); elements with the
  // same shape (structured meshes) share one eigenvalue computation.
  std::map<std::vector<long long>, double> cache;
  double omegaMax = 0.0;
  for (std::size_t e = 0; e < mesh_.numElements(); ++e) {
    const Mat83 X = mesh_.elementCoordinates(e);
    const double h = (X.row(6) - X.row(0)).norm();
    std::vector<long long> key(24);
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i) key[static_cast<std::size_t>(3 * a + i)] = std::llround((X(a, i) - X(0, i)) / h * 1e9);
    key.push_back(static_cast<long long>(std::llround(std::log(h) * 1e9)));
    for (int q = 0; q < 8 && !gaussWeight_.empty(); ++q) key.push_back(std::llround(gaussScale(e)[q] * 1e9));
    auto it = cache.find(key);
    double omega = 0.0;
    if (it != cache.end()) {
      omega = it->second;
    } else {
      Vec24 fe;
      Mat24 Ke;
      ElementEnergy en;
      formulation_->evaluate(e, Mat83::Zero(), fe, &Ke, en);
      const Eigen::Matrix<double, 8, 8> m = massScale_ * elementMass(X, material_->density(), gaussScale(e));
      Vec24 dinv;
      for (int a = 0; a < 8; ++a)
        for (int i = 0; i < 3; ++i) dinv(3 * a + i) = 1.0 / std::sqrt(m.row(a).sum());
      const Eigen::Matrix<double, 24, 24> A = dinv.asDiagonal() * Eigen::Matrix<double, 24, 24>(Ke) * dinv.asDiagonal();
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 24, 24>> eig(A, Eigen::EigenvaluesOnly);
      omega = std::sqrt(std::max(eig.eigenvalues().maxCoeff(), 0.0));
      cache.emplace(std::move(key), omega);
    }
    omegaMax = std::max(omegaMax, omega);
  }
  if (!(omegaMax > 0.0)) return 0.0;
  // Liu 2016 Eq. 65: dt <= 2 / omega_max (sqrt(1 + xi^2) - xi) with xi the
  // damping fraction at omega_max: alpha / (2 omega) for mass-proportional
  // damping C = alpha M, beta omega / 2 for stiffness-proportional C = beta K.
  const double xi = dampingAlpha / (2.0 * omegaMax) + 0.5 * formulation_->stiffnessDamping() * omegaMax;
  return 2.0 / omegaMax * (std::sqrt(1.0 + xi * xi) - xi);
}

void Model::checkFinite(const std::vector<double>& x, const std::string& what) const {
  if (sumOverDofs(x.size(), [&](std::size_t d) { return std::isfinite(x[d]) ? 0.0 : 1.0; }) == 0.0) return;
  for (std::size_t d = 0; d < x.size(); ++d)
    if (!std::isfinite(x[d])) {
      std::ostringstream msg;
      msg << "non-finite " << what << " at node " << d / 3 << " direction " << "xyz"[d % 3];
      throw SolveError(msg.str());
    }
}

}  // namespace cosim::fem
