#pragma once
// A name -> factory registry: every extension point (material, element
// formulation) registers itself from its own .cpp file with a static
// Registrar, so an extension is one new file.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cosim/fem/types.hpp"

namespace cosim::fem {

template <class Base, class... Args>
class Registry {
 public:
  using Factory = std::function<std::unique_ptr<Base>(Args...)>;
  static Registry& instance() {
    static Registry registry;
    return registry;
  }
  void add(const std::string& name, Factory factory) { factories_[name] = std::move(factory); }
  bool has(const std::string& name) const { return factories_.count(name) != 0; }
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& entry : factories_) out.push_back(entry.first);
    return out;
  }
  std::unique_ptr<Base> create(const std::string& name, Args... args) const {
    auto it = factories_.find(name);
    if (it == factories_.end()) {
      std::string known;
      for (const auto& entry : factories_) known += (known.empty() ? "" : ", ") + entry.first;
      throw InputError("unknown " + Base::registryKind() + " '" + name + "' (known: " + known + ")");
    }
    return it->second(std::forward<Args>(args)...);
  }
  struct Registrar {
    Registrar(const std::string& name, Factory factory) { Registry::instance().add(name, std::move(factory)); }
  };

 private:
  std::map<std::string, Factory> factories_;
};

}  // namespace cosim::fem
