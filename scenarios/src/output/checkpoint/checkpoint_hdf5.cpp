// Checkpoint files through HDF5 (checkpoint_file.hpp).
#include "output/checkpoint/checkpoint_file.hpp"

#include "output/hdf5_util.hpp"
#include "output/replacing_file.hpp"

#include <nonholo/version.hpp>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <utility>
#include <vector>

namespace nonholo::scenarios {
namespace {

void dataset(hid_t file, const std::string& path, const char* name, hid_t file_type, hid_t memory_type,
             const void* data, hsize_t n) {
  Handle space = check(H5Screate_simple(1, &n, nullptr), H5Sclose, path, std::string("make the space of ") + name);
  Handle d = check(H5Dcreate2(file, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose,
                   path, std::string("create ") + name);
  if (n > 0) check(H5Dwrite(d.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), path, std::string("write ") + name);
}

[[noreturn]] void not_a_checkpoint(const std::string& path, const std::string& why) {
  throw std::invalid_argument("--resume " + path + ": " + why);
}

std::string read_text(hid_t on, const std::string& path, const char* name) {
  std::string out;
  if (!read_text_attribute(on, path, name, out))
    not_a_checkpoint(path, std::string("no attribute '") + name + "': not a nonholo checkpoint");
  return out;
}

template <class T>
T read_number(hid_t on, const std::string& path, const char* name, hid_t memory_type) {
  if (H5Aexists(on, name) <= 0) not_a_checkpoint(path, std::string("no attribute '") + name + "': not a nonholo checkpoint");
  Handle a = check(H5Aopen(on, name, H5P_DEFAULT), H5Aclose, path, std::string("open attribute ") + name);
  T value{};
  check(H5Aread(a.get(), memory_type, &value), path, std::string("read attribute ") + name);
  return value;
}

}  // namespace

void write_checkpoint(const std::string& path, const CheckpointInfo& info, const std::string& bytes, ConstVecRef q,
                      ConstVecRef p, FileLock* lock) {
  ReplacingFile replacing(path);  // never a fixed name: a link planted there was followed
  const std::string& temporary = replacing.temporary();
  {
    const Quiet quiet;
    Handle file = create_file(temporary);
    const hid_t f = file.get();
    attribute(f, temporary, "format", std::string("nonholo checkpoint"));
    attribute(f, temporary, "format_version", kCheckpointFormat);
    attribute(f, temporary, "nonholo_version", std::string(kVersion));
    attribute(f, temporary, "git_revision", std::string(kGitRevision));
    attribute(f, temporary, "scene", info.scene);
    attribute(f, temporary, "method", info.method);
    attribute(f, temporary, "t", info.t);
    attribute(f, temporary, "step", info.step);
    attribute(f, temporary, "run_id", info.run_id);
    dataset(f, temporary, "bytes", H5T_STD_U8LE, H5T_NATIVE_UCHAR, bytes.data(), bytes.size());
    dataset(f, temporary, "q", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, q.data(), static_cast<hsize_t>(q.size()));
    dataset(f, temporary, "p", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, p.data(), static_cast<hsize_t>(p.size()));
    if (!file.reset()) fail(temporary, "close the file");
  }
  FileLock fresh = lock ? FileLock::take(temporary, "checkpoint") : FileLock();
  replacing.commit();
  if (lock) *lock = std::move(fresh);
}

std::string read_checkpoint(const std::string& path, CheckpointInfo* info) {
  const Quiet quiet;
  if (::access(path.c_str(), R_OK) != 0) not_a_checkpoint(path, std::string("cannot read it: ") + std::strerror(errno));
  const hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) not_a_checkpoint(path, "not an HDF5 file (or a damaged one)");
  Handle file(id, H5Fclose);
  const hid_t f = file.get();
  const std::string format = read_text(f, path, "format");
  if (format != "nonholo checkpoint")
    not_a_checkpoint(path, "a '" + format + "' file, not a nonholo checkpoint (resume from the file --checkpoint wrote)");
  const long version = read_number<long>(f, path, "format_version", H5T_NATIVE_LONG);
  if (version != kCheckpointFormat)
    not_a_checkpoint(path, "checkpoint format " + std::to_string(version) + ", this nonholo reads format " +
                               std::to_string(kCheckpointFormat) + " (resume it with the nonholo that wrote it)");
  const std::string written_by = read_text(f, path, "nonholo_version");
  if (written_by != kVersion)
    not_a_checkpoint(path, "written by nonholo " + written_by + ", this is nonholo " + kVersion +
                               ": resume it with the version that wrote it (a run continued by another version would "
                               "not be the same trajectory)");
  if (info) {
    info->scene = read_text(f, path, "scene");
    info->method = read_text(f, path, "method");
    info->t = read_number<double>(f, path, "t", H5T_NATIVE_DOUBLE);
    info->step = read_number<long>(f, path, "step", H5T_NATIVE_LONG);
    info->run_id = read_text(f, path, "run_id");
  }
  if (H5Lexists(f, "bytes", H5P_DEFAULT) <= 0) not_a_checkpoint(path, "no dataset /bytes");
  Handle d = check(H5Dopen2(f, "bytes", H5P_DEFAULT), H5Dclose, path, "open /bytes");
  Handle space = check(H5Dget_space(d.get()), H5Sclose, path, "read /bytes");
  hsize_t n = 0;
  if (H5Sget_simple_extent_ndims(space.get()) != 1) not_a_checkpoint(path, "/bytes is not 1-D");
  H5Sget_simple_extent_dims(space.get(), &n, nullptr);
  std::string bytes(static_cast<std::size_t>(n), '\0');
  if (n > 0) check(H5Dread(d.get(), H5T_NATIVE_UCHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data()), path, "read /bytes");
  return bytes;
}

}  // namespace nonholo::scenarios
