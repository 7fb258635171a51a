#include <cstring>

#include "cosim/coupler/couplings/coupling.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::coupler {

void InputAssembler::stageArray(std::string name, std::uint32_t components, std::span<const double> values) {
  arrays_.push_back({std::move(name), components, values});
}

std::size_t InputAssembler::words() const {
  std::size_t w = 64;
  for (const auto& a : arrays_) w += a.values.size() + 8 + a.name.size() / 8;
  return w;
}

void InputAssembler::build(proto::CouplingData::Builder data) {
  if (!arrays_.empty()) {
    auto list = data.initArrays(static_cast<unsigned>(arrays_.size()));
    for (unsigned i = 0; i < arrays_.size(); ++i)
      wire::addArray(list, i, arrays_[i].name, arrays_[i].components, arrays_[i].values);
  }
  arrays_.clear();
}

}  // namespace cosim::coupler
