#pragma once
// Plain binary records in checkpoints: trivially copyable values and vectors
// of them (a count, then the items), read back with every count bounded by
// what the file still holds, so a corrupt count is refused before it
// allocates. Errors name the file and the record.
#include <cstddef>
#include <cstdint>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "cosim/util/stream_size.hpp"

namespace cosim::util {

class BinaryWriter {
 public:
  explicit BinaryWriter(std::ostream& out) : out_(out) {}
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes(&v, sizeof(T));
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    pod(static_cast<std::uint64_t>(v.size()));
    bytes(v.data(), v.size() * sizeof(T));
  }
  void bytes(const void* data, std::size_t n) {
    out_.write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
  }

 private:
  std::ostream& out_;
};

class BinaryReader {
 public:
  BinaryReader(std::istream& in, std::string path) : in_(in), path_(std::move(path)) {}
  template <class T>
  T pod(const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    T v{};
    in_.read(reinterpret_cast<char*>(&v), sizeof(T));
    if (!in_) fail(what, "cut short");
    return v;
  }
  template <class T>
  std::vector<T> vec(const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto n = pod<std::uint64_t>(what);
    if (n > bytesLeft(in_, n * sizeof(T)) / sizeof(T)) fail(what, "count beyond the end of the file");
    std::vector<T> v(n);
    in_.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
    if (!in_) fail(what, "cut short");
    return v;
  }
  [[noreturn]] void fail(const char* what, const std::string& why) const {
    throw std::runtime_error(path_ + ": " + what + ": " + why);
  }

 private:
  std::istream& in_;
  std::string path_;
};

}  // namespace cosim::util
