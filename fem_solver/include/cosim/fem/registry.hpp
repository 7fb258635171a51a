#pragma once
// FEM extension points (materials, element formulations) live in the
// project's one registry; this adapter keeps the FEM's lookup, which reports
// an unknown name as InputError naming the kind (Base::registryKind()).
#include "cosim/fem/types.hpp"
#include "cosim/util/registry.hpp"

namespace cosim::fem {

template <class Base, class... Args>
class Registry : public cosim::Registry<Base, Args...> {
  using Shared = cosim::Registry<Base, Args...>;

 public:
  static Registry& instance() {
    static Registry registry;
    return registry;
  }
  std::unique_ptr<Base> create(const std::string& name, Args... args) const {
    if (!Shared::has(name))
      throw InputError("unknown " + Base::registryKind() + " '" + name + "' (known: " + Shared::namesJoined() + ")");
    return Shared::make(name, std::forward<Args>(args)...);
  }
  /// `const FormulationRegistry::Registrar kFull("full", factory);` in the implementation's file.
  struct Registrar {
    Registrar(const std::string& name, typename Shared::Factory factory) { Shared::add(name, std::move(factory)); }
  };
};

}  // namespace cosim::fem
