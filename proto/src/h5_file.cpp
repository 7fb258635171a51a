#include "cosim/io/h5_file.hpp"

#include <algorithm>
#include <stdexcept>

namespace cosim::io {
namespace {

[[noreturn]] void fail(const std::filesystem::path& file, const std::string& what) {
  throw std::runtime_error(file.string() + ": HDF5: " + what);
}

void quietErrors() {
  // Our own messages name file and object; HDF5's stack dumps only add noise.
  static const bool once = [] { return H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr) >= 0; }();
  (void)once;
}

hid_t check(hid_t id, const std::filesystem::path& file, const std::string& what) {
  if (id < 0) fail(file, what);
  return id;
}

constexpr hsize_t kChunkRows = 256;

}  // namespace

H5File H5File::create(const std::filesystem::path& path) {
  quietErrors();
  const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  return H5File(check(f, path, "cannot create the file"), path);
}

H5File H5File::openReadOnly(const std::filesystem::path& path) {
  quietErrors();
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  return H5File(check(f, path, "cannot open the file (missing or not HDF5)"), path);
}

H5File H5File::createOrKeep(const std::filesystem::path& path, bool keep) {
  return keep && std::filesystem::exists(path) ? openForAppend(path) : create(path);
}

H5File H5File::openForAppend(const std::filesystem::path& path) {
  quietErrors();
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  return H5File(check(f, path, "cannot open the file for writing (missing or not HDF5)"), path);
}

H5File::H5File(H5File&& o) noexcept : file_(o.file_), path_(std::move(o.path_)), groups_(std::move(o.groups_)) {
  o.file_ = -1;
  o.groups_.clear();
}

H5File& H5File::operator=(H5File&& o) noexcept {
  if (this != &o) {
    close();
    file_ = o.file_;
    path_ = std::move(o.path_);
    groups_ = std::move(o.groups_);
    o.file_ = -1;
    o.groups_.clear();
  }
  return *this;
}

H5File::~H5File() { close(); }

void H5File::close() {
  for (auto& [name, g] : groups_) H5Gclose(g);
  groups_.clear();
  if (file_ >= 0) H5Fclose(file_);
  file_ = -1;
}

hid_t H5File::group(const std::string& path) {
  if (path.empty() || path == "/") return file_;
  if (auto it = groups_.find(path); it != groups_.end()) return it->second;
  const auto slash = path.find_last_of('/');
  const hid_t parent = group(slash == 0 ? "/" : path.substr(0, slash));
  const std::string leaf = path.substr(slash + 1);
  hid_t g = H5Lexists(parent, leaf.c_str(), H5P_DEFAULT) > 0
                ? H5Gopen2(parent, leaf.c_str(), H5P_DEFAULT)
                : H5Gcreate2(parent, leaf.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  groups_[path] = check(g, path_, "cannot open or create group " + path);
  return groups_[path];
}

void H5File::setAttribute(const std::string& object, const std::string& name, double value) {
  const hid_t space = H5Screate(H5S_SCALAR);
  if (H5Aexists_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT) > 0)
    H5Adelete_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT);
  const hid_t a = H5Acreate_by_name(file_, object.c_str(), name.c_str(), H5T_NATIVE_DOUBLE, space,
                                    H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Sclose(space);
  check(a, path_, "cannot write attribute " + object + "@" + name);
  H5Awrite(a, H5T_NATIVE_DOUBLE, &value);
  H5Aclose(a);
}

void H5File::setAttribute(const std::string& object, const std::string& name, const std::string& value) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, std::max<std::size_t>(value.size(), 1));
  H5Tset_strpad(type, H5T_STR_NULLPAD);
  const hid_t space = H5Screate(H5S_SCALAR);
  if (H5Aexists_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT) > 0)
    H5Adelete_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT);
  const hid_t a = H5Acreate_by_name(file_, object.c_str(), name.c_str(), type, space, H5P_DEFAULT,
                                    H5P_DEFAULT, H5P_DEFAULT);
  H5Sclose(space);
  if (a < 0) {
    H5Tclose(type);
    fail(path_, "cannot write attribute " + object + "@" + name);
  }
  H5Awrite(a, type, value.empty() ? " " : value.data());
  H5Aclose(a);
  H5Tclose(type);
}

namespace {
template <typename T>
void writeTyped(H5File& f, const std::string& path, std::span<const T> values, std::size_t cols, hid_t type) {
  const auto slash = path.find_last_of('/');
  const hid_t parent = f.group(slash == 0 ? "/" : path.substr(0, slash));
  const std::string leaf = path.substr(slash + 1);
  if (cols == 0 || values.size() % cols != 0)
    fail(f.path(), path + ": " + std::to_string(values.size()) + " values do not fill rows of " + std::to_string(cols));
  const hsize_t dims[2] = {values.size() / cols, cols};
  const hid_t space = H5Screate_simple(cols == 1 ? 1 : 2, dims, nullptr);
  if (H5Lexists(parent, leaf.c_str(), H5P_DEFAULT) > 0) H5Ldelete(parent, leaf.c_str(), H5P_DEFAULT);
  const hid_t d = H5Dcreate2(parent, leaf.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Sclose(space);
  check(d, f.path(), "cannot create dataset " + path);
  const herr_t status = values.empty() ? 0 : H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
  H5Dclose(d);
  if (status < 0) fail(f.path(), "cannot write dataset " + path);
}
}  // namespace

void H5File::writeArray(const std::string& path, std::span<const double> values, std::size_t cols) {
  writeTyped(*this, path, values, cols, H5T_NATIVE_DOUBLE);
}
void H5File::writeArray(const std::string& path, std::span<const std::uint32_t> values, std::size_t cols) {
  writeTyped(*this, path, values, cols, H5T_NATIVE_UINT32);
}

bool H5File::exists(const std::string& path) const {
  // Check each link along the path: H5Lexists fails on a missing intermediate group.
  std::size_t pos = 1;
  while (pos <= path.size()) {
    const auto next = path.find('/', pos);
    const std::string prefix = path.substr(0, next);
    if (H5Lexists(file_, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (next == std::string::npos) break;
    pos = next + 1;
  }
  return true;
}

double H5File::attribute(const std::string& object, const std::string& name, double fallback) const {
  if (H5Aexists_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT) <= 0) return fallback;
  const hid_t a = H5Aopen_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
  double v = fallback;
  const herr_t status = a < 0 ? -1 : H5Aread(a, H5T_NATIVE_DOUBLE, &v);
  if (a >= 0) H5Aclose(a);
  if (status < 0) fail(path_, "cannot read attribute " + object + "@" + name);
  return v;
}

namespace {
herr_t collectNames(hid_t, const char* name, const H5L_info_t*, void* out) {
  static_cast<std::vector<std::string>*>(out)->emplace_back(name);
  return 0;
}
}  // namespace

std::vector<std::string> H5File::children(const std::string& group) const {
  std::vector<std::string> names;
  if (!exists(group)) return names;
  const hid_t g = check(H5Gopen2(file_, group.c_str(), H5P_DEFAULT), path_, "no group " + group);
  H5Literate(g, H5_INDEX_NAME, H5_ITER_INC, nullptr, collectNames, &names);
  H5Gclose(g);
  return names;
}

namespace {
// Fixed-size attributes (doubles, fixed strings: all this file writes) copied byte for byte.
herr_t copyAttribute(hid_t from, const char* name, const H5A_info_t*, void* to) {
  const hid_t a = H5Aopen(from, name, H5P_DEFAULT);
  if (a < 0) return -1;
  const hid_t type = H5Aget_type(a), space = H5Aget_space(a);
  std::vector<char> bytes(std::max<std::size_t>(H5Aget_storage_size(a), H5Tget_size(type)));
  herr_t status = H5Aread(a, type, bytes.data());
  const hid_t b = status < 0 ? -1 : H5Acreate2(*static_cast<hid_t*>(to), name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  status = b < 0 ? -1 : H5Awrite(b, type, bytes.data());
  if (b >= 0) H5Aclose(b);
  H5Sclose(space);
  H5Tclose(type);
  H5Aclose(a);
  return status;
}

struct TreeCopy {
  hid_t from, to;
  const std::vector<std::string>& drop;
  const std::filesystem::path& file;

  bool dropped(const std::string& path) const { return std::find(drop.begin(), drop.end(), path) != drop.end(); }
  bool holdsDropped(const std::string& path) const {
    return std::any_of(drop.begin(), drop.end(), [&](const std::string& d) { return d.rfind(path + "/", 0) == 0; });
  }
  void attributes(const std::string& object) const {
    const hid_t src = H5Oopen(from, object.c_str(), H5P_DEFAULT);
    hid_t dst = H5Oopen(to, object.c_str(), H5P_DEFAULT);
    const herr_t status = src < 0 || dst < 0 ? -1 : H5Aiterate2(src, H5_INDEX_NAME, H5_ITER_INC, nullptr, copyAttribute, &dst);
    if (src >= 0) H5Oclose(src);
    if (dst >= 0) H5Oclose(dst);
    if (status < 0) fail(file, "cannot copy the attributes of " + object + " into the rewritten file");
  }
  // Copies the members of `group` but the dropped ones; a member that holds a
  // dropped object is made anew and filled the same way.
  void members(const std::string& group) const {
    std::vector<std::string> names;
    const hid_t g = check(H5Gopen2(from, group.c_str(), H5P_DEFAULT), file, "no group " + group);
    H5Literate(g, H5_INDEX_NAME, H5_ITER_INC, nullptr, collectNames, &names);
    H5Gclose(g);
    for (const std::string& name : names) {
      const std::string path = (group == "/" ? "" : group) + "/" + name;
      if (dropped(path)) continue;
      if (holdsDropped(path)) {
        H5Gclose(check(H5Gcreate2(to, path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), file,
                       "cannot create group " + path + " in the rewritten file"));
        attributes(path);
        members(path);
      } else if (H5Ocopy(from, path.c_str(), to, path.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0) {
        fail(file, "cannot copy " + path + " into the rewritten file (damaged before the checkpoint it resumes from?)");
      }
    }
  }
};
}  // namespace

void H5File::rewriteWithout(const std::vector<std::string>& drop) {
  const std::filesystem::path original = path_;
  const std::filesystem::path fresh = original.string() + ".rewrite";
  close();
  try {
    H5File from = openReadOnly(original);
    H5File to = create(fresh);
    TreeCopy copy{from.id(), to.id(), drop, original};
    copy.attributes("/");
    copy.members("/");
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(fresh, ignored);
    throw;
  }
  std::error_code ec;
  std::filesystem::rename(fresh, original, ec);
  if (ec) fail(original, "cannot replace the file by its rewritten copy: " + ec.message());
  *this = openForAppend(original);
}

std::vector<std::size_t> H5File::shape(const std::string& path) const {
  const hid_t d = check(H5Dopen2(file_, path.c_str(), H5P_DEFAULT), path_, "no dataset " + path);
  const hid_t space = H5Dget_space(d);
  hsize_t dims[8] = {};
  const int rank = H5Sget_simple_extent_dims(space, dims, nullptr);
  H5Sclose(space);
  H5Dclose(d);
  return std::vector<std::size_t>(dims, dims + std::max(rank, 0));
}

std::vector<double> H5File::readArray(const std::string& path) const {
  const hid_t d = check(H5Dopen2(file_, path.c_str(), H5P_DEFAULT), path_, "no dataset " + path);
  const hid_t space = H5Dget_space(d);
  const auto n = static_cast<std::size_t>(H5Sget_simple_extent_npoints(space));
  H5Sclose(space);
  std::vector<double> out(n);
  const herr_t status = n ? H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) : 0;
  H5Dclose(d);
  if (status < 0) fail(path_, "cannot read dataset " + path);
  return out;
}

void H5File::flush() {
  if (file_ >= 0) H5Fflush(file_, H5F_SCOPE_GLOBAL);
}

SeriesWriter::SeriesWriter(H5File& file, std::string group) : file_(file), group_(std::move(group)) {
  file_.group(group_);
}

SeriesWriter::~SeriesWriter() {
  try {
    flush();
  } catch (const std::exception&) {
    // A destructor cannot report; what was flushed before stays readable.
  }
  for (auto& [name, d] : datasets_) H5Dclose(d.id);
}

SeriesWriter::Dataset& SeriesWriter::dataset(const std::string& name, std::size_t cols) {
  if (auto it = datasets_.find(name); it != datasets_.end()) {
    if (it->second.cols != cols)
      fail(file_.path(), group_ + "/" + name + " has " + std::to_string(it->second.cols) +
                             " columns, a row of " + std::to_string(cols) + " was appended");
    return it->second;
  }
  const hsize_t dims[2] = {0, cols};
  const hsize_t maxDims[2] = {H5S_UNLIMITED, cols};
  const hsize_t chunk[2] = {kChunkRows, cols};
  const int rank = cols == 1 ? 1 : 2;
  const hid_t space = H5Screate_simple(rank, dims, maxDims);
  const hid_t props = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(props, rank, chunk);
  // A name with slashes ("left/energy/kinetic") lives in nested groups.
  const std::string full = group_ + "/" + name;
  const auto slash = full.find_last_of('/');
  const hid_t parent = file_.group(full.substr(0, slash));
  const hid_t d = H5Dcreate2(parent, full.substr(slash + 1).c_str(), H5T_NATIVE_DOUBLE, space, H5P_DEFAULT,
                             props, H5P_DEFAULT);
  H5Pclose(props);
  H5Sclose(space);
  check(d, file_.path(), "cannot create series " + group_ + "/" + name);
  auto& ds = datasets_[name];
  ds.id = d;
  ds.cols = cols;
  if (auto u = pendingUnits_.find(name); u != pendingUnits_.end())
    file_.setAttribute(group_ + "/" + name, "units", u->second);
  return ds;
}

void SeriesWriter::append(const std::string& name, double value) { append(name, std::span<const double>(&value, 1)); }

void SeriesWriter::append(const std::string& name, std::span<const double> row) {
  auto& d = dataset(name, row.size());
  d.pending.insert(d.pending.end(), row.begin(), row.end());
}

void SeriesWriter::flush() {
  for (auto& [name, d] : datasets_) {
    if (d.pending.empty()) continue;
    const hsize_t added = d.pending.size() / d.cols;
    const int rank = d.cols == 1 ? 1 : 2;
    const hsize_t newDims[2] = {d.rows + added, d.cols};
    if (H5Dset_extent(d.id, newDims) < 0) fail(file_.path(), "cannot extend " + name);
    const hid_t fileSpace = H5Dget_space(d.id);
    const hsize_t start[2] = {d.rows, 0};
    const hsize_t count[2] = {added, d.cols};
    H5Sselect_hyperslab(fileSpace, H5S_SELECT_SET, start, nullptr, count, nullptr);
    const hid_t memSpace = H5Screate_simple(rank, count, nullptr);
    const herr_t status = H5Dwrite(d.id, H5T_NATIVE_DOUBLE, memSpace, fileSpace, H5P_DEFAULT, d.pending.data());
    H5Sclose(memSpace);
    H5Sclose(fileSpace);
    if (status < 0) fail(file_.path(), "cannot append to " + name);
    d.rows += added;
    d.pending.clear();
  }
  file_.flush();
}

void SeriesWriter::setUnits(const std::string& name, const std::string& units) {
  if (datasets_.count(name)) file_.setAttribute(group_ + "/" + name, "units", units);
  else pendingUnits_[name] = units;
}

namespace {
herr_t collectDatasets(hid_t group, const char* name, const H5L_info_t*, void* out) {
  H5O_info_t info;
  if (H5Oget_info_by_name(group, name, &info, H5P_DEFAULT) >= 0 && info.type == H5O_TYPE_DATASET)
    static_cast<std::vector<std::string>*>(out)->emplace_back(name);
  return 0;
}
}  // namespace

void SeriesWriter::resumeAt(std::size_t rows) {
  resumeWith([rows](const std::string&) { return rows; });
}

void SeriesWriter::resumeAt(const std::map<std::string, std::size_t>& rowsOf) {
  resumeWith([&rowsOf](const std::string& name) {
    const auto it = rowsOf.find(name);
    return it == rowsOf.end() ? std::size_t{0} : it->second;
  });
}

void SeriesWriter::resumeWith(const std::function<std::size_t(const std::string&)>& rowsOf) {
  std::vector<std::string> names;
  H5Lvisit(file_.group(group_), H5_INDEX_NAME, H5_ITER_INC, collectDatasets, &names);
  for (const auto& name : names) {
    if (datasets_.count(name)) continue;
    const std::string full = group_ + "/" + name;
    const hid_t d = check(H5Dopen2(file_.id(), full.c_str(), H5P_DEFAULT), file_.path(), "cannot open " + full);
    const hid_t space = H5Dget_space(d);
    hsize_t dims[2] = {0, 1};
    const int rank = H5Sget_simple_extent_dims(space, dims, nullptr);
    H5Sclose(space);
    const std::size_t cols = rank == 2 ? dims[1] : 1;
    const std::size_t rows = rowsOf(name);
    const hsize_t cut[2] = {std::min<hsize_t>(dims[0], rows), cols};
    if (H5Dset_extent(d, cut) < 0) fail(file_.path(), "cannot cut " + full + " back to " + std::to_string(rows) + " rows");
    auto& ds = datasets_[name];
    ds.id = d;
    ds.cols = cols;
    ds.rows = cut[0];
  }
}

std::map<std::string, std::size_t> SeriesWriter::rowCounts() const {
  std::map<std::string, std::size_t> out;
  for (const auto& [name, ds] : datasets_) out[name] = rows(name);
  return out;
}

std::size_t SeriesWriter::rows(const std::string& name) const {
  auto it = datasets_.find(name);
  return it == datasets_.end() ? 0 : it->second.rows + it->second.pending.size() / it->second.cols;
}

}  // namespace cosim::io
