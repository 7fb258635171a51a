#pragma once
// A registry of named factories: the extension points (contact laws,
// integrators, PD models, materials, element formulations, CG kernels,
// schedules, couplings, reference solutions ...) are looked up by the name a
// config uses, so adding one is adding one file that registers itself:
//
//   const bool registered = NormalLawRegistry::add("hertz", [] { return std::make_unique<HertzNormal>(); });
//
// Link libraries that register through static objects as OBJECT libraries (or
// whole-archive), otherwise the linker drops the registering translation units.
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace cosim {

template <typename Base, typename... Args>
class Registry {
 public:
  using Factory = std::function<std::unique_ptr<Base>(Args...)>;

  static bool add(const std::string& name, Factory factory) {
    return entries().emplace(name, std::move(factory)).second;
  }
  static bool has(const std::string& name) { return entries().count(name) > 0; }
  /// Null when nothing is registered under name.
  static std::unique_ptr<Base> make(const std::string& name, Args... args) {
    auto it = entries().find(name);
    if (it == entries().end()) return nullptr;
    return it->second(std::forward<Args>(args)...);
  }
  /// Throws std::invalid_argument naming the unknown name, what it is, and the known ones.
  static std::unique_ptr<Base> create(const std::string& name, const std::string& what, Args... args) {
    if (!has(name)) throw std::invalid_argument("unknown " + what + " '" + name + "' (known: " + namesJoined() + ")");
    return make(name, std::forward<Args>(args)...);
  }
  static std::vector<std::string> names() {
    std::vector<std::string> out;
    for (const auto& [name, f] : entries()) out.push_back(name);
    return out;
  }
  /// "a, b, c" for messages.
  static std::string namesJoined() {
    std::string out;
    for (const auto& [name, f] : entries()) out += (out.empty() ? "" : ", ") + name;
    return out;
  }

 private:
  static std::map<std::string, Factory>& entries() {
    static std::map<std::string, Factory> map;
    return map;
  }
};

}  // namespace cosim
