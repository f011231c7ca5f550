// A run's HDF5 output read back (results.hpp).
#include <nonholo/scenarios/results.hpp>

#include "output/hdf5_util.hpp"

#include <stdexcept>

namespace nonholo::scenarios {
namespace {

// A 1-D or 2-D float64 dataset, row-major into `out` (resized); its dimensions.
std::vector<hsize_t> read_doubles(hid_t f, const std::string& path, const char* name, std::vector<double>& out) {
  if (H5Lexists(f, name, H5P_DEFAULT) <= 0) throw std::invalid_argument("'" + path + "' has no dataset " + name);
  Handle d = check(H5Dopen2(f, name, H5P_DEFAULT), H5Dclose, path, std::string("open ") + name);
  Handle space = check(H5Dget_space(d.get()), H5Sclose, path, std::string("read the size of ") + name);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(static_cast<std::size_t>(std::max(rank, 0)));
  H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  hsize_t n = 1;
  for (hsize_t x : dims) n *= x;
  out.resize(n);
  if (n > 0) check(H5Dread(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), path, std::string("read ") + name);
  return dims;
}

std::vector<std::string> read_names(hid_t f, const std::string& path, const char* name) {
  Handle d = check(H5Dopen2(f, name, H5P_DEFAULT), H5Dclose, path, std::string("open ") + name);
  Handle space = check(H5Dget_space(d.get()), H5Sclose, path, std::string("read the size of ") + name);
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space.get(), &n, nullptr);
  std::vector<char*> text(n);
  Handle type = string_type(path);
  if (n > 0) check(H5Dread(d.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data()), path, std::string("read ") + name);
  std::vector<std::string> out(text.begin(), text.end());
  if (n > 0) H5Dvlen_reclaim(type.get(), space.get(), H5P_DEFAULT, text.data());
  return out;
}

// Every attribute of /summary: numbers and texts.
herr_t read_attribute(hid_t on, const char* name, const H5A_info_t*, void* data) {
  auto* d = static_cast<RunData*>(data);
  Handle a(H5Aopen(on, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(a.get()), H5Tclose);
  if (H5Tget_class(type.get()) == H5T_STRING) {
    Handle text_type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(text_type.get(), H5T_VARIABLE);
    char* text = nullptr;
    if (H5Aread(a.get(), text_type.get(), &text) >= 0) d->summary_text[name] = text ? text : "";
    H5free_memory(text);
  } else {
    double value = 0.0;
    if (H5Aread(a.get(), H5T_NATIVE_DOUBLE, &value) >= 0) d->summary[name] = value;
  }
  return 0;
}

}  // namespace

RunData load_run_hdf5(const std::string& path) {
  const Quiet quiet;
  Handle file = open_for_reading(path);  // (a run killed while writing too)
  if (!file) throw std::invalid_argument("cannot read '" + path + "' (not an HDF5 file, or a damaged one)");
  const hid_t f = file.get();
  std::string format;
  read_text_attribute(f, path, "format", format);
  if (format != "nonholo run")
    throw std::invalid_argument("'" + path + "' is a '" + format + "' file, not a run's output");
  RunData d;
  d.coordinates = read_names(f, path, "coordinates");
  d.velocities = H5Lexists(f, "velocities", H5P_DEFAULT) > 0 ? read_names(f, path, "velocities") : d.coordinates;
  std::vector<double> buffer;
  auto vector = [&](const char* name, Vector& out) {
    read_doubles(f, path, name, buffer);
    out = Eigen::Map<const Vector>(buffer.data(), static_cast<Eigen::Index>(buffer.size()));
  };
  auto matrix = [&](const char* name, Eigen::MatrixXd& out) {
    const auto dims = read_doubles(f, path, name, buffer);
    const auto rows = static_cast<Eigen::Index>(dims.at(0)), columns = static_cast<Eigen::Index>(dims.size() > 1 ? dims[1] : 1);
    out = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(buffer.data(), rows, columns);
  };
  vector("t", d.t);
  matrix("q", d.q);
  matrix("p", d.p);
  vector("energy", d.energy);
  vector("energy_post", d.energy_post);
  vector("residual", d.residual);
  vector("gap", d.gap);
  if (H5Lexists(f, "summary", H5P_DEFAULT) > 0) {
    Handle g = check(H5Gopen2(f, "summary", H5P_DEFAULT), H5Gclose, path, "open /summary");
    hsize_t at = 0;
    H5Aiterate2(g.get(), H5_INDEX_NAME, H5_ITER_INC, &at, read_attribute, &d);
  }
  return d;
}

}  // namespace nonholo::scenarios
