#pragma once
// Binary checkpoint of a whole DemSystem: particles, materials, walls, the
// neighbour list with every contact's history, and the counters. Restoring
// it and advancing gives bit-for-bit the same trajectory as not stopping.
#include <cstdint>
#include <istream>
#include <ostream>
#include <string>

#include "cosim/dem/dem_system.hpp"

namespace cosim::dem {

/// Writes the state; returns the bytes written. Throws naming the path.
std::uint64_t writeCheckpoint(const DemSystem& system, const std::string& path);
/// Replaces system's state with the file's. Throws naming the path on a bad file.
void readCheckpoint(DemSystem& system, const std::string& path);
/// The same on an open stream (several systems in one file, e.g. the unit cells
/// of a GMH worker); path only names the file in messages. Returns the stream
/// position after the record.
std::uint64_t writeCheckpoint(const DemSystem& system, std::ostream& out, const std::string& path);
void readCheckpoint(DemSystem& system, std::istream& in, const std::string& path);

}  // namespace cosim::dem
