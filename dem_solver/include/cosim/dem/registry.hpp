#pragma once
// A registry of implementations keyed by the name a scene uses. Each
// implementation file registers itself with a static Registrar, so adding a
// contact law, wall type or integrator is adding one file.
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>

namespace cosim::dem {

template <class Base>
class Registry {
 public:
  using Factory = std::function<std::unique_ptr<Base>()>;
  static bool add(const std::string& name, Factory factory) {
    entries().emplace(name, std::move(factory));
    return true;
  }
  static bool has(const std::string& name) { return entries().count(name) > 0; }
  /// Throws naming the unknown key and the known ones.
  static std::unique_ptr<Base> create(const std::string& name, const std::string& what) {
    const auto it = entries().find(name);
    if (it == entries().end()) {
      std::string known;
      for (const auto& [key, value] : entries()) known += (known.empty() ? "" : ", ") + key;
      throw std::invalid_argument("unknown " + what + " '" + name + "' (known: " + known + ")");
    }
    return it->second();
  }

 private:
  static std::map<std::string, Factory>& entries() {
    static std::map<std::string, Factory> map;
    return map;
  }
};

}  // namespace cosim::dem
