#pragma once
// The HDF5 C API's handles and the few calls nonholo's files need (run and batch output,
// checkpoints): every handle owned by an RAII holder, HDF5's own error printing off inside our
// calls (a failure becomes our exception naming the path and what failed). Internal: only the
// files built with HDF5 include it.
#include <hdf5.h>

#include <cstdint>
#include <string>
#include <utility>

namespace nonholo::scenarios {

// An hid_t closed by its kind's close function.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, H5I_INVALID_HID)), close_(o.close_) {}
  Handle& operator=(Handle&& o) noexcept {
    reset();
    id_ = std::exchange(o.id_, H5I_INVALID_HID);
    close_ = o.close_;
    return *this;
  }
  ~Handle() { reset(); }
  hid_t get() const { return id_; }
  explicit operator bool() const { return id_ >= 0; }
  // Closes now; false when HDF5 reports an error (a file whose last writes failed).
  bool reset() {
    bool ok = true;
    if (id_ >= 0 && close_) ok = close_(id_) >= 0;
    id_ = H5I_INVALID_HID;
    return ok;
  }

 private:
  hid_t id_ = H5I_INVALID_HID;
  herr_t (*close_)(hid_t) = nullptr;
};

// HDF5 prints its error stack on stderr by default: off while we call it.
class Quiet {
 public:
  Quiet() { H5Eget_auto2(H5E_DEFAULT, &func_, &data_), H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }
  ~Quiet() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

[[noreturn]] inline void fail(const std::string& path, const std::string& what) {
  throw std::runtime_error("error writing '" + path + "': HDF5 could not " + what);
}

inline Handle check(hid_t id, herr_t (*close)(hid_t), const std::string& path, const std::string& what) {
  if (id < 0) fail(path, what);
  return Handle(id, close);
}

inline void check(herr_t status, const std::string& path, const std::string& what) {
  if (status < 0) fail(path, what);
}

// swmr: in the latest file format, which single-writer/multiple-reader writing needs.
inline Handle create_file(const std::string& path, bool swmr = false) {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (swmr && fapl) H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
  const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl ? fapl.get() : H5P_DEFAULT);
  if (f < 0) throw std::invalid_argument("cannot open '" + path + "' for writing (HDF5)");
  return Handle(f, H5Fclose);
}

// A variable-length UTF-8 string type (what h5py reads as str).
inline Handle string_type(const std::string& path) {
  Handle t = check(H5Tcopy(H5T_C_S1), H5Tclose, path, "make a string type");
  check(H5Tset_size(t.get(), H5T_VARIABLE), path, "make a string type");
  check(H5Tset_cset(t.get(), H5T_CSET_UTF8), path, "make a string type");
  return t;
}

inline void attribute(hid_t on, const std::string& path, const std::string& name, double value) {
  Handle space = check(H5Screate(H5S_SCALAR), H5Sclose, path, "make a scalar space");
  Handle a = check(H5Acreate2(on, name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                   path, "create attribute " + name);
  check(H5Awrite(a.get(), H5T_NATIVE_DOUBLE, &value), path, "write attribute " + name);
}

inline void attribute(hid_t on, const std::string& path, const std::string& name, long value) {
  const std::int64_t v = value;
  Handle space = check(H5Screate(H5S_SCALAR), H5Sclose, path, "make a scalar space");
  Handle a = check(H5Acreate2(on, name.c_str(), H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                   path, "create attribute " + name);
  check(H5Awrite(a.get(), H5T_NATIVE_INT64, &v), path, "write attribute " + name);
}

inline void attribute(hid_t on, const std::string& path, const std::string& name, const std::string& value) {
  Handle type = string_type(path);
  Handle space = check(H5Screate(H5S_SCALAR), H5Sclose, path, "make a scalar space");
  Handle a = check(H5Acreate2(on, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose, path,
                   "create attribute " + name);
  const char* text = value.c_str();
  check(H5Awrite(a.get(), type.get(), &text), path, "write attribute " + name);
}

// A string attribute into `out`; false (out untouched) when `on` has none of that name.
inline bool read_text_attribute(hid_t on, const std::string& path, const char* name, std::string& out) {
  if (H5Aexists(on, name) <= 0) return false;
  Handle a = check(H5Aopen(on, name, H5P_DEFAULT), H5Aclose, path, std::string("open attribute ") + name);
  Handle type = string_type(path);
  char* text = nullptr;
  check(H5Aread(a.get(), type.get(), &text), path, std::string("read attribute ") + name);
  out = text ? text : "";
  H5free_memory(text);
  return true;
}

// A file opened for reading, also one whose writer was killed while writing it single-writer/
// multiple-reader (the mark it left refuses a plain open); an empty Handle when neither works.
inline Handle open_for_reading(const std::string& path) {
  hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) id = H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, H5P_DEFAULT);
  return id < 0 ? Handle() : Handle(id, H5Fclose);
}

inline Handle group(hid_t file, const std::string& path, const char* name) {
  return check(H5Gcreate2(file, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, path,
               std::string("create group ") + name);
}

}  // namespace nonholo::scenarios
