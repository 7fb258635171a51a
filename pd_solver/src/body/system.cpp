// Assembly of a PdSystem: bodies, neighbour lists, models, particle sets.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "cosim/pd/hybrid.hpp"
#include "cosim/pd/system.hpp"

namespace cosim::pd {
namespace {

// Smallest distance-based overlap test: a particle of the new body closer
// than half the smaller spacing to a particle of an earlier body, or inside
// the analytic shape of an earlier body, means the bodies overlap.
void checkOverlap(const Particles& p, const std::vector<Body>& bodies, const BodySpec& spec,
                  const PointCloud& cloud, double spacing) {
  for (const auto& other : bodies) {
    const double r = 0.5 * std::min(spacing, other.spacing);
    const double cell = std::max(spacing, other.spacing);
    std::unordered_map<long long, std::vector<std::size_t>> grid;
    auto key = [&](const double* x) {
      long long k = 0;
      for (int a = 0; a < 3; ++a) k = k * 2000003LL + static_cast<long long>(std::floor(x[a] / cell));
      return k;
    };
    for (std::size_t i = other.begin; i < other.end; ++i) grid[key(&p.reference[3 * i])].push_back(i);
    for (std::size_t q = 0; q < cloud.volumes.size(); ++q) {
      const double* x = &cloud.positions[3 * q];
      bool hit = other.spec.shape != Shape::Points && insideShape(other.spec, x, -1e-9 * other.spacing);
      for (int dx = -1; dx <= 1 && !hit; ++dx)
        for (int dy = -1; dy <= 1 && !hit; ++dy)
          for (int dz = -1; dz <= 1 && !hit; ++dz) {
            const double y[3] = {x[0] + dx * cell, x[1] + dy * cell, x[2] + dz * cell};
            const auto it = grid.find(key(y));
            if (it == grid.end()) continue;
            for (const std::size_t i : it->second) {
              double d2 = 0.0;
              for (int a = 0; a < 3; ++a) d2 += (p.reference[3 * i + a] - x[a]) * (p.reference[3 * i + a] - x[a]);
              if (d2 < r * r) { hit = true; break; }
            }
          }
      if (hit)
        throw std::invalid_argument("body '" + spec.name + "' overlaps body '" + other.spec.name +
                                    "' (point " + std::to_string(q) + ")");
    }
  }
}

}  // namespace

std::size_t PdSystem::addBody(const BodySpec& spec) {
  if (spec.shape == Shape::Points) {
    if (spec.pointsFile.empty()) throw std::invalid_argument("body '" + spec.name + "': points body needs a file");
    PointCloud cloud;
    try {
      cloud = readPointFile(spec.pointsFile);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("body '" + spec.name + "': " + e.what());
    }
    return addBody(spec, cloud);
  }
  return addBody(spec, discretise(spec));
}

std::size_t PdSystem::addBody(const BodySpec& spec, const PointCloud& cloud) {
  if (finalised_) throw std::logic_error("PdSystem: bodies must be added before finalise()");
  const auto fail = [&](const std::string& what) {
    throw std::invalid_argument("body '" + spec.name + "': " + what);
  };
  for (const auto& b : bodies_)
    if (b.spec.name == spec.name) fail("duplicate body name");
  if (!ModelRegistry::has(spec.model)) {
    try { ModelRegistry::create(spec.model, "PD model"); } catch (const std::exception& e) { fail(e.what()); }
  }
  if (!(spec.material.youngsModulus > 0.0)) fail("E must be positive");
  if (!(spec.material.density > 0.0)) fail("rho must be positive");
  if (!(spec.material.poissonRatio > -1.0 && spec.material.poissonRatio < 0.5)) fail("nu must be in (-1, 0.5)");
  if (!(spec.horizonFactor > 0.0) || !std::isfinite(spec.horizonFactor)) fail("horizon must be positive");
  if (spec.options.criticalStretch < 0.0) fail("critical_stretch must be non-negative");
  double mean = 0.0;
  for (std::size_t q = 0; q < cloud.volumes.size(); ++q) {
    const double v = cloud.volumes[q];
    if (!(v > 0.0) || !std::isfinite(v)) fail("volume of point " + std::to_string(q) + " is not positive");
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(cloud.positions[3 * q + a])) fail("point " + std::to_string(q) + " is NaN or infinite");
    mean += v;
  }
  if (cloud.volumes.empty()) fail("no particles");
  mean /= static_cast<double>(cloud.volumes.size());
  double h = spec.spacing;
  if (spec.shape == Shape::Points && !(h > 0.0)) h = std::cbrt(mean);
  if (!(h > 0.0) || !std::isfinite(h)) fail("spacing must be positive");
  if (cloud.volumes.size() < 2) {
    std::ostringstream why;
    why << "1 particle at spacing " << h << " (horizon " << spec.horizonFactor
        << " x spacing): a body needs at least 2; use "
        << (spec.shape == Shape::Points ? "a 'file' with more points" : "a 'spacing' finer than the body");
    fail(why.str());
  }
  std::string key;
  if (const auto why = bodySizeProblem(spec, static_cast<double>(cloud.volumes.size()), key); !why.empty()) fail(why);
  checkOverlap(particles_, bodies_, spec, cloud, h);

  Body body;
  body.spec = spec;
  body.spacing = h;
  body.horizon = spec.horizonFactor * h;
  body.begin = particles_.size();
  const auto index = static_cast<std::uint32_t>(bodies_.size());
  for (std::size_t q = 0; q < cloud.volumes.size(); ++q)
    particles_.append(&cloud.positions[3 * q], cloud.volumes[q],
                      spec.material.density * cloud.volumes[q], index);
  body.end = particles_.size();
  for (std::size_t i = body.begin; i < body.end; ++i)
    for (int a = 0; a < 3; ++a) particles_.velocity[3 * i + a] = spec.initialVelocity[a];
  body.model = ModelRegistry::create(spec.model, "PD model");
  bodies_.push_back(std::move(body));
  return index;
}

BodyContext PdSystem::context(std::size_t b) const {
  const Body& body = bodies_[b];
  return BodyContext{particles_, body.bonds, body.begin, body.end, body.spec.material,
                     body.horizon, body.spacing, body.spec.options};
}

std::vector<std::uint32_t> PdSystem::select(const Selection& where) const {
  std::vector<std::uint32_t> out;
  bool bodyFound = where.body.empty();
  for (const auto& body : bodies_) {
    if (!where.body.empty() && body.spec.name != where.body) continue;
    bodyFound = true;
    for (std::size_t i = body.begin; i < body.end; ++i) {
      if (where.hasBox) {
        bool inside = true;
        for (int a = 0; a < 3; ++a) {
          const double x = particles_.reference[3 * i + a];
          inside = inside && x >= where.min[a] && x <= where.max[a];
        }
        if (!inside) continue;
      }
      out.push_back(static_cast<std::uint32_t>(i));
    }
  }
  if (!bodyFound) throw std::invalid_argument("selection names unknown body '" + where.body + "'");
  return out;
}

// A particle with no partner has no stiffness (LPS: zero weighted volume).
// Partners at delta + h/2 that round-off puts a hair inside count with a
// fraction of about 1e-13 and do not count here.
void PdSystem::buildBody(std::size_t b) {
  Body& body = bodies_[b];
  const auto particles = static_cast<double>(body.end - body.begin);
  body.bonds = buildBonds(particles_, body.begin, body.end, body.horizon, body.spacing, body.spec.options.partialVolume,
                          [&](std::size_t bonds) {
                            if (const auto why = bondCountProblem(body.spec, particles, static_cast<double>(bonds));
                                !why.empty())
                              throw EntryError(EntryError::Entry::Body, b, "body '" + body.spec.name + "': " + why);
                          });
  const auto& bonds = body.bonds;
  for (std::size_t q = 0; q < bonds.rows(); ++q) {
    double partners = 0.0;
    for (std::size_t k = bonds.offset[q]; k < bonds.offset[q + 1]; ++k) partners += bonds.volumeFraction[k];
    if (partners > 1e-6) continue;
    const double* x = &particles_.reference[3 * (body.begin + q)];
    std::ostringstream why;
    why << "body '" << body.spec.name << "': particle " << q << " at (" << x[0] << ", " << x[1] << ", " << x[2]
        << ") has no partner within the horizon " << body.horizon << " (" << body.spec.horizonFactor
        << " x spacing " << body.spacing << ", " << bonds.rows()
        << " particles): every particle needs one; use a larger 'horizon'";
    throw EntryError(EntryError::Entry::Body, b, why.str());
  }
  try {
    body.model->initialise(context(b));
  } catch (const std::invalid_argument& e) {
    throw EntryError(EntryError::Entry::Body, b, "body '" + body.spec.name + "': " + e.what());
  }
}

std::vector<std::uint32_t> PdSystem::resolve(const Selection& where, EntryError::Entry entry,
                                             std::size_t index) const {
  std::vector<std::uint32_t> out;
  try {
    out = select(where);
  } catch (const std::invalid_argument& e) {
    throw EntryError(entry, index, e.what());
  }
  if (out.empty()) {
    std::ostringstream why;
    why << (entry == EntryError::Entry::Load ? "load" : "boundary condition") << " selects no particle";
    if (!where.body.empty()) why << " of body '" << where.body << "'";
    if (where.hasBox)
      why << " in the box [" << where.min[0] << ", " << where.min[1] << ", " << where.min[2] << "] to ["
          << where.max[0] << ", " << where.max[1] << ", " << where.max[2] << "]";
    throw EntryError(entry, index, why.str());
  }
  return out;
}

void PdSystem::finalise() {
  if (finalised_) return;
  if (bodies_.empty()) throw std::invalid_argument("no PD bodies defined");
  for (std::size_t b = 0; b < bodies_.size(); ++b) buildBody(b);
  for (std::size_t k = 0; k < bcs_.size(); ++k) {
    auto& bc = bcs_[k];
    bc.particles = resolve(bc.where, EntryError::Entry::Boundary, k);
    if (bc.type == Constraint::NormalOnly) {
      // Interior particles of the set have no normal and stay free.
      std::vector<std::uint32_t> kept;
      for (const auto i : bc.particles) {
        double n[3];
        if (!surfaceNormal(particles_, bodies_[particles_.body[i]].bonds, i, n)) continue;
        kept.push_back(i);
        bc.normals.insert(bc.normals.end(), n, n + 3);
      }
      if (kept.empty())
        throw EntryError(EntryError::Entry::Boundary, k,
                         "normal boundary condition selects no surface particle (interior particles have no normal)");
      bc.particles = std::move(kept);
    }
  }
  for (std::size_t k = 0; k < loads_.size(); ++k) loads_[k].particles = resolve(loads_[k].where, EntryError::Entry::Load, k);
  indexConstraints();
  coupling_.assign(3 * particles_.size(), 0.0);
  finalised_ = true;
  applyConstraints();
  computeForces();
  externalPrev_ = particles_.externalForce;
}

void PdSystem::indexConstraints() {
  const std::size_t n = particles_.size();
  constraintOffset_.assign(n + 1, 0);
  for (const auto& bc : bcs_)
    for (const auto i : bc.particles) ++constraintOffset_[i + 1];
  for (std::size_t i = 0; i < n; ++i) constraintOffset_[i + 1] += constraintOffset_[i];
  constraintEntry_.resize(constraintOffset_[n]);
  auto next = constraintOffset_;
  for (std::uint32_t k = 0; k < bcs_.size(); ++k)
    for (std::uint32_t q = 0; q < bcs_[k].particles.size(); ++q) constraintEntry_[next[bcs_[k].particles[q]]++] = {k, q};
}

std::vector<double> PdSystem::damageField() const {
  std::vector<double> out;
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const auto d = damage(context(b));
    out.insert(out.end(), d.begin(), d.end());
  }
  return out;
}

CorrespondenceFields PdSystem::correspondenceFields() const {
  CorrespondenceFields all;
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    auto f = correspondence(context(b));
    auto cat = [](std::vector<double>& a, const std::vector<double>& x) { a.insert(a.end(), x.begin(), x.end()); };
    cat(all.deformationGradient, f.deformationGradient);
    cat(all.greenLagrange, f.greenLagrange);
    cat(all.pk2, f.pk2);
    cat(all.cauchy, f.cauchy);
    cat(all.vonMises, f.vonMises);
  }
  return all;
}

}  // namespace cosim::pd
