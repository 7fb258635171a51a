#pragma once
// Minimal process-wide logging to stderr: one line per event, prefixed by the
// process's role so interleaved output of several processes stays readable.
#include <string>

namespace cosim::log {

enum class Level { debug = 0, info = 1, warn = 2, error = 3, quiet = 4 };

void setPrefix(std::string prefix);
void setLevel(Level level);
Level level();
/// Parses "debug", "info", "warn", "error", "quiet"; throws on anything else.
Level parseLevel(const std::string& name);

void debug(const std::string& message);
void info(const std::string& message);
void warn(const std::string& message);
void error(const std::string& message);

}  // namespace cosim::log
