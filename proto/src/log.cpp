#include "cosim/wire/log.hpp"

#include <atomic>
#include <cstdio>
#include <mutex>
#include <stdexcept>

namespace cosim::log {
namespace {
std::mutex& mutex() {
  static std::mutex m;
  return m;
}
std::string& prefix() {
  static std::string p;
  return p;
}
std::atomic<Level>& currentLevel() {
  static std::atomic<Level> l{Level::info};
  return l;
}
void write(Level lvl, const char* tag, const std::string& message) {
  if (lvl < currentLevel().load()) return;
  std::lock_guard lock(mutex());
  std::fprintf(stderr, "%s%s%s\n", prefix().c_str(), tag, message.c_str());
  std::fflush(stderr);
}
}  // namespace

void setPrefix(std::string p) {
  std::lock_guard lock(mutex());
  prefix() = p.empty() ? std::string() : "[" + p + "] ";
}
void setLevel(Level l) { currentLevel() = l; }
Level level() { return currentLevel(); }

Level parseLevel(const std::string& name) {
  if (name == "debug") return Level::debug;
  if (name == "info") return Level::info;
  if (name == "warn") return Level::warn;
  if (name == "error") return Level::error;
  if (name == "quiet") return Level::quiet;
  throw std::invalid_argument("unknown log level '" + name +
                              "' (expected debug, info, warn, error or quiet)");
}

void debug(const std::string& m) { write(Level::debug, "debug: ", m); }
void info(const std::string& m) { write(Level::info, "", m); }
void warn(const std::string& m) { write(Level::warn, "warning: ", m); }
void error(const std::string& m) { write(Level::error, "error: ", m); }

}  // namespace cosim::log
