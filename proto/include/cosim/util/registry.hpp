#pragma once
// A registry of named factories: the extension points (contact laws, PD
// models, CG kernels, schedules, couplings, reference solutions ...) are
// looked up by the name a config uses, so adding one is adding one file with
// a COSIM_REGISTER line.
//
// Link libraries that register through static objects as OBJECT libraries (or
// whole-archive), otherwise the linker drops the registering translation units.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace cosim {

template <typename Base, typename... Args>
class Registry {
 public:
  using Factory = std::function<std::unique_ptr<Base>(Args...)>;

  static Registry& instance() {
    static Registry registry;
    return registry;
  }
  bool add(const std::string& name, Factory factory) {
    return factories_.emplace(name, std::move(factory)).second;
  }
  bool has(const std::string& name) const { return factories_.count(name) > 0; }
  /// Null when nothing is registered under name.
  std::unique_ptr<Base> make(const std::string& name, Args... args) const {
    auto it = factories_.find(name);
    if (it == factories_.end()) return nullptr;
    return it->second(std::forward<Args>(args)...);
  }
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& [name, f] : factories_) out.push_back(name);
    return out;
  }
  /// "a, b, c" for messages.
  std::string namesJoined() const {
    std::string out;
    for (const auto& [name, f] : factories_) out += (out.empty() ? "" : ", ") + name;
    return out;
  }

 private:
  std::map<std::string, Factory> factories_;
};

}  // namespace cosim

#define COSIM_REGISTRY_CONCAT_(a, b) a##b
#define COSIM_REGISTRY_CONCAT(a, b) COSIM_REGISTRY_CONCAT_(a, b)
/// COSIM_REGISTER(RegistryType, "name", factory-lambda) at namespace scope.
#define COSIM_REGISTER(RegistryType, name, ...)                                         \
  [[maybe_unused]] static const bool COSIM_REGISTRY_CONCAT(cosimRegistered_, __LINE__) = \
      RegistryType::instance().add(name, __VA_ARGS__)
