#pragma once
// Zero-copy views of flat Cap'n Proto arrays (List(Float64), List(UInt32)) as
// spans, and bulk fills of builder lists from contiguous memory.
#include <capnp/list.h>

#include <cstdint>
#include <span>
#include <string_view>

#include "data.capnp.h"

namespace cosim::wire {

std::span<const double> view(capnp::List<double>::Reader list);
std::span<const std::uint32_t> view(capnp::List<std::uint32_t>::Reader list);
std::span<double> view(capnp::List<double>::Builder list);
std::span<std::uint32_t> view(capnp::List<std::uint32_t>::Builder list);

/// Appends a named array to the container being built (one memcpy).
void addArray(capnp::List<proto::NamedArray>::Builder arrays, unsigned index, std::string_view name,
              std::uint32_t components, std::span<const double> values);

/// Finds a named array; null reader (empty values) when absent.
const proto::NamedArray::Reader* findArray(capnp::List<proto::NamedArray>::Reader arrays,
                                           std::string_view name, proto::NamedArray::Reader& out);

/// 64-bit FNV-1a over raw bytes: a bit-for-bit fingerprint of a payload.
std::uint64_t fingerprint(std::span<const double> values);

}  // namespace cosim::wire
