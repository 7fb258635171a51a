#include <cstring>

#include "cosim/coupler/couplings/coupling.hpp"
#include "cosim/wire/arrays.hpp"
#include "cosim/wire/weight_profile.hpp"

namespace cosim::coupler {
namespace {

template <typename T, typename List>
void copyInto(List list, std::span<const T> values) {
  auto out = wire::view(list);
  if (!values.empty()) std::memcpy(out.data(), values.data(), values.size() * sizeof(T));
}

}  // namespace

void InputAssembler::stageArray(std::string name, std::uint32_t components, std::span<const double> values) {
  arrays_.push_back({std::move(name), components, values});
}

std::size_t InputAssembler::words() const {
  std::size_t w = 64;
  for (const auto& a : arrays_) w += a.values.size() + 8 + a.name.size() / 8;
  for (const auto& m : meshes_)
    w += m.positions.size() + m.velocities.size() + m.triangles.size() / 2 + 16 + m.surface.size() / 8;
  for (const auto& f : forces_) w += f.forces.size() + f.ids.size() / 2 + 12 + f.zone.size() / 8;
  w += 16 * profiles_.size();
  for (const auto& j : jobs_) w += j.strainIncrements.size() + j.cellIds.size() / 2 + 16;
  for (const auto& r : results_) w += r.stresses.size() + 4 * r.cellIds.size() + 32;
  for (const auto& h : hybridParticles_)
    w += h.ids.size() + h.referencePositions.size() + h.positions.size() + h.velocities.size() + h.radii.size() +
         h.horizons.size() + h.indices.size() / 2 + 40;
  for (const auto& h : hybridForces_)
    w += h.ids.size() / 2 + h.forces.size() + h.positions.size() + h.stiffness.size() + h.watch.watched.size() / 2 + 24;
  return w;
}

void InputAssembler::clear() {
  arrays_.clear();
  meshes_.clear();
  forces_.clear();
  profiles_.clear();
  jobs_.clear();
  results_.clear();
  hybridParticles_.clear();
  hybridForces_.clear();
}

void InputAssembler::buildHybrid(proto::CouplingData::Builder data) const {
  if (!hybridParticles_.empty()) {
    auto list = data.initHybridParticles(static_cast<unsigned>(hybridParticles_.size()));
    for (unsigned i = 0; i < hybridParticles_.size(); ++i) {
      const auto& h = hybridParticles_[i];
      auto out = list[i];
      copyInto(out.initIds(static_cast<unsigned>(h.ids.size())), h.ids);
      copyInto(out.initBodyIds(static_cast<unsigned>(h.bodyIds.size())), h.bodyIds);
      copyInto(out.initReferencePositions(static_cast<unsigned>(h.referencePositions.size())), h.referencePositions);
      copyInto(out.initPositions(static_cast<unsigned>(h.positions.size())), h.positions);
      copyInto(out.initVelocities(static_cast<unsigned>(h.velocities.size())), h.velocities);
      copyInto(out.initRadii(static_cast<unsigned>(h.radii.size())), h.radii);
      copyInto(out.initHorizons(static_cast<unsigned>(h.horizons.size())), h.horizons);
      out.setWantStiffness(h.wantStiffness);
      out.setSerial(h.serial);
      out.setPartial(h.partial);
      out.setWatchBasis(h.watchBasis);
      if (h.partial) copyInto(out.initIndices(static_cast<unsigned>(h.indices.size())), h.indices);
    }
  }
  if (!hybridForces_.empty()) {
    auto list = data.initHybridForces(static_cast<unsigned>(hybridForces_.size()));
    for (unsigned i = 0; i < hybridForces_.size(); ++i) {
      const auto& h = hybridForces_[i];
      copyInto(list[i].initIds(static_cast<unsigned>(h.ids.size())), h.ids);
      copyInto(list[i].initForces(static_cast<unsigned>(h.forces.size())), h.forces);
      const auto& w = h.watch;
      list[i].setSendAll(w.sendAll);
      if (w.watchSet) {
        list[i].setWatchSet(true);
        copyInto(list[i].initWatched(static_cast<unsigned>(w.watched.size())), w.watched);
        list[i].setWatchMargin(w.margin);
        list[i].setWatchInterval(w.interval);
        list[i].setWatchBasis(w.basis);
      }
      if (h.stiffness.empty()) continue;
      copyInto(list[i].initPositions(static_cast<unsigned>(h.positions.size())), h.positions);
      copyInto(list[i].initStiffness(static_cast<unsigned>(h.stiffness.size())), h.stiffness);
    }
  }
}

void InputAssembler::build(proto::CouplingData::Builder data) {
  if (!arrays_.empty()) {
    auto list = data.initArrays(static_cast<unsigned>(arrays_.size()));
    for (unsigned i = 0; i < arrays_.size(); ++i)
      wire::addArray(list, i, arrays_[i].name, arrays_[i].components, arrays_[i].values);
  }
  if (!meshes_.empty()) {
    auto list = data.initMeshes(static_cast<unsigned>(meshes_.size()));
    for (unsigned i = 0; i < meshes_.size(); ++i) {
      const auto& m = meshes_[i];
      auto out = list[i];
      out.setSurface(m.surface);
      copyInto(out.initPositions(static_cast<unsigned>(m.positions.size())), m.positions);
      copyInto(out.initVelocities(static_cast<unsigned>(m.velocities.size())), m.velocities);
      copyInto(out.initTriangles(static_cast<unsigned>(m.triangles.size())), m.triangles);
    }
  }
  if (!forces_.empty()) {
    auto list = data.initForces(static_cast<unsigned>(forces_.size()));
    for (unsigned i = 0; i < forces_.size(); ++i) {
      const auto& f = forces_[i];
      auto out = list[i];
      out.setZone(f.zone);
      out.setTarget(f.target);
      copyInto(out.initIds(static_cast<unsigned>(f.ids.size())), f.ids);
      copyInto(out.initForces(static_cast<unsigned>(f.forces.size())), f.forces);
    }
  }
  if (!profiles_.empty()) {
    auto list = data.initWeightProfiles(static_cast<unsigned>(profiles_.size()));
    for (unsigned i = 0; i < profiles_.size(); ++i) wire::write(profiles_[i], list[i]);
  }
  buildUnitCells(data);
  buildHybrid(data);
  clear();
}

void InputAssembler::buildUnitCells(proto::CouplingData::Builder data) const {
  if (!jobs_.empty()) {
    auto list = data.initUnitCellJobs(static_cast<unsigned>(jobs_.size()));
    for (unsigned i = 0; i < jobs_.size(); ++i) {
      copyInto(list[i].initCellIds(static_cast<unsigned>(jobs_[i].cellIds.size())), jobs_[i].cellIds);
      copyInto(list[i].initStrainIncrements(static_cast<unsigned>(jobs_[i].strainIncrements.size())),
               jobs_[i].strainIncrements);
      list[i].setDt(jobs_[i].dt);
    }
  }
  if (!results_.empty()) {
    auto list = data.initUnitCellResults(static_cast<unsigned>(results_.size()));
    for (unsigned i = 0; i < results_.size(); ++i) {
      const auto& r = results_[i];
      auto out = list[i];
      copyInto(out.initCellIds(static_cast<unsigned>(r.cellIds.size())), r.cellIds);
      copyInto(out.initStresses(static_cast<unsigned>(r.stresses.size())), r.stresses);
      copyInto(out.initPorosities(static_cast<unsigned>(r.porosities.size())), r.porosities);
      copyInto(out.initCoordinationNumbers(static_cast<unsigned>(r.coordinationNumbers.size())), r.coordinationNumbers);
      copyInto(out.initUnbalancedForceIndices(static_cast<unsigned>(r.unbalancedForceIndices.size())),
               r.unbalancedForceIndices);
      copyInto(out.initRelaxationSteps(static_cast<unsigned>(r.relaxationSteps.size())), r.relaxationSteps);
    }
  }
}

}  // namespace cosim::coupler
