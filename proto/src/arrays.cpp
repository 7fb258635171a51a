#include "cosim/wire/arrays.hpp"
#include "cosim/wire/segment_pool.hpp"

#include <capnp/any.h>

#include <bit>
#include <cstring>
#include <string>

namespace cosim::wire {
namespace {
template <typename T>
std::span<const T> rawView(capnp::AnyList::Reader any) {
  auto bytes = any.getRawBytes();
  return {reinterpret_cast<const T*>(bytes.begin()), bytes.size() / sizeof(T)};
}
}  // namespace

// Cap'n Proto stores primitive lists contiguously in little-endian order, which
// is the host order on every platform we build for (checked at compile time).
static_assert(std::endian::native == std::endian::little, "the wire assumes a little-endian host");

std::span<const double> view(capnp::List<double>::Reader list) {
  return rawView<double>(capnp::AnyList::Reader(list));
}
std::span<const std::uint32_t> view(capnp::List<std::uint32_t>::Reader list) {
  return rawView<std::uint32_t>(capnp::AnyList::Reader(list));
}
std::span<double> view(capnp::List<double>::Builder list) {
  auto ro = view(list.asReader());
  // The builder owns this memory; the reader view only lacks the const-free type.
  return {const_cast<double*>(ro.data()), ro.size()};
}
std::span<std::uint32_t> view(capnp::List<std::uint32_t>::Builder list) {
  auto ro = view(list.asReader());
  return {const_cast<std::uint32_t*>(ro.data()), ro.size()};
}

void addArray(capnp::List<proto::NamedArray>::Builder arrays, unsigned index, std::string_view name,
              std::uint32_t components, std::span<const double> values) {
  auto a = arrays[index];
  a.setName(kj::StringPtr(std::string(name).c_str()));
  a.setComponents(components);
  std::span<double> dst;
  {
    // Every word of the list is written below, so a large one may take an unzeroed segment.
    PooledMessageBuilder::PayloadScope payload(values.size());
    dst = view(a.initValues(static_cast<unsigned>(values.size())));
  }
  if (!values.empty()) std::memcpy(dst.data(), values.data(), values.size_bytes());
}

const proto::NamedArray::Reader* findArray(capnp::List<proto::NamedArray>::Reader arrays,
                                           std::string_view name, proto::NamedArray::Reader& out) {
  for (auto a : arrays) {
    auto n = a.getName();
    if (std::string_view(n.cStr(), n.size()) == name) {
      out = a;
      return &out;
    }
  }
  return nullptr;
}

std::uint64_t fingerprint(std::span<const double> values) {
  std::uint64_t h = 1469598103934665603ull;
  const auto* p = reinterpret_cast<const unsigned char*>(values.data());
  for (std::size_t i = 0; i < values.size_bytes(); ++i) {
    h ^= p[i];
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace cosim::wire
