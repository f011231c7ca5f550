// HDF5 output through the C API of Debian's serial HDF5 (hdf5_output.hpp). Every handle is
// owned by an RAII holder; HDF5's own error printing is silenced inside our calls (a failure
// becomes our exception with the path and what failed, not a stack dump on stderr).
#include "output/hdf5_output.hpp"
#include "output/hdf5_util.hpp"
#include "output/xdmf.hpp"

#include <hdf5.h>
#include <nlohmann/json.hpp>
#include <nonholo/build_config.hpp>
#include <nonholo/version.hpp>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <type_traits>
#include <utility>

namespace nonholo::scenarios {
namespace {

// What the numbers are in (docs/guide/command-line.md "Units"): no unit is fixed, the scene's parameters give them.
constexpr const char* kUnits =
    "consistent units, SI suggested (m, kg, s, rad): lengths, masses and times in the units of the scene's "
    "parameters, angles in radians, t in the time unit, p in mass x length / time";

// The run's options and the scene on the root, the scene's parameters on /parameters. `c` has the
// dt and t_end the run used (not the 0 and -1 that mean "the scene's"); steps: of dt each.
void describe_run(hid_t file, const std::string& path, const RunConfig& c, const std::string& scene,
                  const Parameters* params, long steps) {
  attribute(file, path, "nonholo_version", std::string(kVersion));
  attribute(file, path, "git_revision", std::string(kGitRevision));  // at configure time
  attribute(file, path, "target_arch", std::string(kTargetArch));  // "portable" or -march=...
  attribute(file, path, "units", std::string(kUnits));
  attribute(file, path, "command", c.command_line);
  attribute(file, path, "scene", scene);
  attribute(file, path, "method", c.method);
  attribute(file, path, "hitch", std::string(to_string(c.hitch)));
  attribute(file, path, "backend", std::string(sparse::to_string(c.backend)));
  attribute(file, path, "restart", c.restart);
  attribute(file, path, "restart_tol", c.restart_tol);
  attribute(file, path, "monitor_every", static_cast<long>(c.monitor_every));
  attribute(file, path, "order", static_cast<long>(c.order));
  attribute(file, path, "composition", c.composition);
  attribute(file, path, "rotation", c.rotation);
  attribute(file, path, "dt", c.dt);
  attribute(file, path, "t_end", c.t_end);
  attribute(file, path, "steps", steps);
  attribute(file, path, "every", c.every);
  attribute(file, path, "tol", c.tol);
  attribute(file, path, "adaptive", static_cast<long>(c.adaptive));
  attribute(file, path, "project", static_cast<long>(c.project));
  attribute(file, path, "error_estimate", static_cast<long>(c.error_estimate));
  if (!params) return;
  Handle g = group(file, path, "parameters");
  for (const auto& spec : params->specs()) attribute(g.get(), path, spec.name, (*params)[spec.name]);
}

void describe_summary(hid_t file, const std::string& path, const RunSummary& s, const char* name = "summary") {
  Handle g = group(file, path, name);
  for (const SummaryField& f : s.fields()) {
    if (f.kind == SummaryField::Number)
      attribute(g.get(), path, f.key, f.number);
    else if (f.kind == SummaryField::Integer)
      attribute(g.get(), path, f.key, f.integer);
    else
      attribute(g.get(), path, f.key, f.text);
  }
  attribute(g.get(), path, "message", s.message);
  attribute(g.get(), path, "warning", s.warning);
  attribute(g.get(), path, "threads_note", s.threads_note);
  // The warnings one by one with their kinds, as JSON (Python's load reads it back as a list).
  nlohmann::json warnings = nlohmann::json::array();
  for (const RunWarning& w : s.warnings) warnings.push_back({{"kind", to_string(w.kind)}, {"text", w.text}});
  attribute(g.get(), path, "warning_list", warnings.dump());
}

// A dataset of `columns` columns (0: 1-D) that grows by rows: chunked (about 1 MB a chunk),
// shuffled and deflated (level 1: the fast end, most of the gain on smooth data).
class Growing {
 public:
  Growing() = default;
  Growing(hid_t file, const std::string& path, const char* name, hsize_t columns, hsize_t chunk_rows)
      : path_(&path), name_(name), columns_(columns) {
    const int rank = columns > 0 ? 2 : 1;
    const hsize_t dims[2] = {0, columns}, max[2] = {H5S_UNLIMITED, columns}, chunk[2] = {chunk_rows, columns};
    Handle space = check(H5Screate_simple(rank, dims, max), H5Sclose, path, "make the space of " + name_);
    Handle plist = check(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, path, "make a property list");
    check(H5Pset_chunk(plist.get(), rank, chunk), path, "chunk " + name_);
    check(H5Pset_shuffle(plist.get()), path, "shuffle " + name_);
    check(H5Pset_deflate(plist.get(), 1), path, "compress " + name_);
    data_ = check(H5Dcreate2(file, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, plist.get(), H5P_DEFAULT),
                  H5Dclose, path, "create " + name_);
  }
  // An existing dataset (a run continued from a checkpoint), cut back to its first `rows` rows;
  // throws std::invalid_argument when it is missing or holds fewer.
  static Growing reopen(hid_t file, const std::string& path, const char* name, hsize_t columns, hsize_t rows) {
    Growing g;
    g.path_ = &path;
    g.name_ = name;
    g.columns_ = columns;
    if (H5Lexists(file, name, H5P_DEFAULT) <= 0)
      throw std::invalid_argument("cannot continue '" + path + "': it has no dataset " + name);
    g.data_ = check(H5Dopen2(file, name, H5P_DEFAULT), H5Dclose, path, std::string("open ") + name);
    Handle space = check(H5Dget_space(g.data_.get()), H5Sclose, path, std::string("read the size of ") + name);
    hsize_t dims[2] = {0, 0};
    const int rank = H5Sget_simple_extent_ndims(space.get());
    H5Sget_simple_extent_dims(space.get(), dims, nullptr);
    if (rank != (columns > 0 ? 2 : 1) || (columns > 0 && dims[1] != columns) || dims[0] < rows)
      throw std::invalid_argument("cannot continue '" + path + "': its " + name + " holds " + std::to_string(dims[0]) +
                                  " frames where the checkpoint wrote " + std::to_string(rows) +
                                  " (or has another shape): not the output of this run");
    const hsize_t size[2] = {rows, columns};
    check(H5Dset_extent(g.data_.get(), size), path, std::string("cut back ") + name);
    g.rows_ = rows;
    return g;
  }
  hsize_t rows() const { return rows_; }

  // Appends `count` rows from `values` (row-major).
  void append(const double* values, hsize_t count) {
    if (count == 0) return;
    const int rank = columns_ > 0 ? 2 : 1;
    const hsize_t size[2] = {rows_ + count, columns_};
    check(H5Dset_extent(data_.get(), size), *path_, "extend " + name_);
    Handle file_space = check(H5Dget_space(data_.get()), H5Sclose, *path_, "select in " + name_);
    const hsize_t start[2] = {rows_, 0}, block[2] = {count, columns_};
    check(H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start, nullptr, block, nullptr), *path_,
          "select in " + name_);
    Handle memory = check(H5Screate_simple(rank, block, nullptr), H5Sclose, *path_, "make a memory space");
    check(H5Dwrite(data_.get(), H5T_NATIVE_DOUBLE, memory.get(), file_space.get(), H5P_DEFAULT, values), *path_,
          "write " + name_);
    rows_ += count;
  }

 private:
  const std::string* path_ = nullptr;
  std::string name_;
  hsize_t columns_ = 0, rows_ = 0;
  Handle data_;
};

// A fixed 1-D dataset of numbers or strings, written at once (the batch's columns, the names).
template <class T>
void write_column(hid_t file, const std::string& path, const std::string& name, const std::vector<T>& values) {
  static_assert(std::is_same_v<T, double> || std::is_same_v<T, std::int64_t>);
  constexpr bool real = std::is_same_v<T, double>;
  const hsize_t n = values.size();
  Handle space = check(H5Screate_simple(1, &n, nullptr), H5Sclose, path, "make the space of " + name);
  Handle d = check(H5Dcreate2(file, name.c_str(), real ? H5T_IEEE_F64LE : H5T_STD_I64LE, space.get(), H5P_DEFAULT,
                              H5P_DEFAULT, H5P_DEFAULT),
                   H5Dclose, path, "create " + name);
  if (n > 0)
    check(H5Dwrite(d.get(), real ? H5T_NATIVE_DOUBLE : H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()),
          path, "write " + name);
}

void write_column(hid_t file, const std::string& path, const std::string& name, const std::vector<std::string>& values) {
  const hsize_t n = values.size();
  std::vector<const char*> text(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) text[i] = values[i].c_str();
  Handle type = string_type(path);
  Handle space = check(H5Screate_simple(1, &n, nullptr), H5Sclose, path, "make the space of " + name);
  Handle d = check(H5Dcreate2(file, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                   H5Dclose, path, "create " + name);
  if (n > 0) check(H5Dwrite(d.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data()), path, "write " + name);
}

}  // namespace

struct Hdf5RunWriter::Impl {
  std::string path;
  Handle file;
  hsize_t n = 0, buffer_rows = 1, buffered = 0;
  std::vector<std::string> velocities;  // names of p's entries (FrameSink::velocities)
  bool reopened = false;                 // continuing a file (its datasets exist)
  std::vector<std::string> coordinates;  // q's names (the sidecar's columns)

  // From here on the file is written in HDF5's single-writer/multiple-reader mode: its metadata
  // reach the disk in an order that keeps the file readable at any moment (h5py: swmr=True, or
  // nonholo.load), so that a run killed with -9 leaves every frame of the last flush readable.
  void start_swmr() { check(H5Fstart_swmr_write(file.get()), path, "start SWMR writing"); }
  hsize_t frames_at_open = 0;            // then: the frames the checkpoint counted
  Growing t, q, p, energy, energy_post, residual, gap;
  std::vector<double> bt, bq, bp, be, bep, br, bg;  // frames not yet written

  void flush() {
    t.append(bt.data(), buffered);
    q.append(bq.data(), buffered);
    p.append(bp.data(), buffered);
    energy.append(be.data(), buffered);
    energy_post.append(bep.data(), buffered);
    residual.append(br.data(), buffered);
    gap.append(bg.data(), buffered);
    for (auto* b : {&bt, &bq, &bp, &be, &bep, &br, &bg}) b->clear();
    buffered = 0;
  }
};

Hdf5RunWriter::Hdf5RunWriter(const std::string& path, const RunConfig& config, const std::string& scene,
                             const Parameters& params, long steps, const std::string& run_id)
    : impl_(std::make_unique<Impl>()) {
  const Quiet quiet;
  impl_->path = path;
  impl_->file = create_file(path, true);
  attribute(impl_->file.get(), path, "format", std::string("nonholo run"));
  attribute(impl_->file.get(), path, "run_id", run_id);  // the checkpoint's too: whose file it is
  describe_run(impl_->file.get(), path, config, scene, &params, steps);
}

Hdf5RunWriter::~Hdf5RunWriter() {
  if (!impl_ || !impl_->file) return;
  const Quiet quiet;
  try {
    if (impl_->buffered > 0) impl_->flush();
  } catch (const std::exception&) {  // a destructor does not throw: the file is still closed
  }
}

namespace {
// Whether another process holds HDF5's own lock on the file (flock: a reader, h5py say, keeps it
// while the file is open), which makes opening it for writing fail.
bool held_by_a_reader(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);  // (a lock taken here goes with it)
  return held;
}

// The run id a run's file carries ("" when none), read without writing: the file may be another's.
std::string run_id_of(const std::string& path) {
  Handle file = open_for_reading(path);
  if (!file) throw std::invalid_argument("cannot continue '" + path + "': not an HDF5 file, or a damaged one");
  std::string id;
  read_text_attribute(file.get(), path, "run_id", id);
  return id;
}
}  // namespace

Hdf5RunWriter::Hdf5RunWriter(const std::string& path, long frames, const std::string& run_id)
    : impl_(std::make_unique<Impl>()) {
  const Quiet quiet;
  impl_->path = path;
  impl_->reopened = true;
  impl_->frames_at_open = static_cast<hsize_t>(frames);
  const std::string found = run_id_of(path);
  if (found != run_id)
    throw std::invalid_argument("cannot continue '" + path + "': it is not the file this run wrote (its run_id is " +
                                (found.empty() ? std::string("missing") : "'" + found + "'") +
                                ", the checkpoint's '" + run_id +
                                "': another run has written it since); it is left as it is: give the run's file "
                                "back, or start the run afresh");
  // A file killed while SWMR writing keeps that mark, and HDF5 refuses to open it for writing:
  // cleared, as h5clear -s does (a private property of HDF5 1.10's file access lists). Only
  // this run writes it: the output's lock is held (file_lock.hpp).
  Handle fapl = check(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, path, "make a file access list");
  check(H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_LATEST, H5F_LIBVER_LATEST), path, "ask for the latest format");
  hbool_t clear = 1;
  const bool can_clear = H5Pexist(fapl.get(), "clear_status_flags") > 0 &&
                         H5Pset(fapl.get(), "clear_status_flags", &clear) >= 0;
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl.get());
  if (f < 0)
    throw std::invalid_argument(
        "cannot continue '" + path + "': cannot open it for writing (HDF5)" +
        (held_by_a_reader(path) ? std::string("; another program has it open (h5py, HDFView, ...: HDF5 locks a file "
                                              "it reads): close it there and resume again")
         : can_clear ? std::string()
                     : "; if the run that wrote it was killed, `h5clear -s " + path +
                           "` (Debian's hdf5-tools) clears the mark it left"));
  impl_->file = Handle(f, H5Fclose);
  // The summary of the run that wrote the checkpoint's end, if it finished: finish() writes anew.
  if (H5Lexists(f, "summary", H5P_DEFAULT) > 0) check(H5Ldelete(f, "summary", H5P_DEFAULT), path, "remove /summary");
}

void Hdf5RunWriter::begin(const std::vector<std::string>& coordinates) {
  const Quiet quiet;
  Impl& w = *impl_;
  const hid_t f = w.file.get();
  w.n = coordinates.size();
  w.coordinates = coordinates;
  // About 1 MB of q a chunk (at least one frame); the 1-D series chunk as many frames.
  w.buffer_rows = std::max<hsize_t>(1, (hsize_t{1} << 17) / std::max<hsize_t>(1, w.n));
  if (w.reopened) {
    const hsize_t nv = w.velocities.empty() ? w.n : w.velocities.size(), rows = w.frames_at_open;
    w.t = Growing::reopen(f, w.path, "t", 0, rows);
    w.q = Growing::reopen(f, w.path, "q", w.n, rows);
    w.p = Growing::reopen(f, w.path, "p", nv, rows);
    w.energy = Growing::reopen(f, w.path, "energy", 0, rows);
    w.energy_post = Growing::reopen(f, w.path, "energy_post", 0, rows);
    w.residual = Growing::reopen(f, w.path, "residual", 0, rows);
    w.gap = Growing::reopen(f, w.path, "gap", 0, rows);
    w.start_swmr();
    return;
  }
  w.t = Growing(f, w.path, "t", 0, w.buffer_rows);
  w.q = Growing(f, w.path, "q", w.n, w.buffer_rows);
  // p has n_v entries: fewer than q's n_q with rigid bodies (their velocity names then apart).
  const hsize_t nv = w.velocities.empty() ? w.n : w.velocities.size();
  w.p = Growing(f, w.path, "p", nv, w.buffer_rows);
  w.energy = Growing(f, w.path, "energy", 0, w.buffer_rows);
  w.energy_post = Growing(f, w.path, "energy_post", 0, w.buffer_rows);
  w.residual = Growing(f, w.path, "residual", 0, w.buffer_rows);
  w.gap = Growing(f, w.path, "gap", 0, w.buffer_rows);
  write_column(f, w.path, "coordinates", coordinates);
  if (!w.velocities.empty() && w.velocities != coordinates) write_column(f, w.path, "velocities", w.velocities);
  w.start_swmr();
}

void Hdf5RunWriter::velocities(const std::vector<std::string>& names) { impl_->velocities = names; }

void Hdf5RunWriter::frame(double t, ConstVecRef q, ConstVecRef p, const Diagnostics& d) {
  Impl& w = *impl_;
  w.bt.push_back(t);
  w.bq.insert(w.bq.end(), q.data(), q.data() + q.size());
  w.bp.insert(w.bp.end(), p.data(), p.data() + p.size());
  w.be.push_back(d.energy);
  w.bep.push_back(d.energy_post);
  w.br.push_back(d.residual);
  w.bg.push_back(d.gap);
  if (++w.buffered == w.buffer_rows) {
    const Quiet quiet;
    w.flush();
  }
}

void Hdf5RunWriter::end() {
  const Quiet quiet;
  impl_->flush();
}

long Hdf5RunWriter::flush_to_disk() {
  const Quiet quiet;
  Impl& w = *impl_;
  w.flush();
  check(H5Fflush(w.file.get(), H5F_SCOPE_GLOBAL), w.path, "flush the file");
  return static_cast<long>(w.t.rows());
}

namespace {
// FILE.xdmf beside FILE.h5 (output/xdmf.hpp), from the file's /t and /coordinates.
void write_sidecar(Hdf5RunWriter::Impl& w) {
  const hid_t f = w.file.get();
  Handle t = check(H5Dopen2(f, "t", H5P_DEFAULT), H5Dclose, w.path, "open /t");
  Handle space = check(H5Dget_space(t.get()), H5Sclose, w.path, "read the size of /t");
  hsize_t frames = 0;
  H5Sget_simple_extent_dims(space.get(), &frames, nullptr);
  std::vector<double> times(static_cast<std::size_t>(frames));
  if (frames > 0) check(H5Dread(t.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, times.data()), w.path, "read /t");
  const auto slash = w.path.rfind('/');
  const std::string name = slash == std::string::npos ? w.path : w.path.substr(slash + 1);
  const std::string xml = xdmf_for(name, w.coordinates, times);
  if (xml.empty()) return;
  const auto dot = w.path.rfind('.');
  const std::string sidecar = w.path.substr(0, dot) + ".xdmf";
  std::ofstream out(sidecar);
  out << xml;
  out.close();
  if (!out) throw std::runtime_error("error writing '" + sidecar + "'");
}
}  // namespace

void Hdf5RunWriter::finish(const RunSummary& summary) {
  const Quiet quiet;
  Impl& w = *impl_;
  if (w.buffered > 0) w.flush();
  for (Growing* d : {&w.t, &w.q, &w.p, &w.energy, &w.energy_post, &w.residual, &w.gap}) *d = Growing();
  // SWMR writing creates no objects: the summary goes in after the frames, the file reopened.
  if (!w.file.reset()) fail(w.path, "close the file");
  const hid_t f = H5Fopen(w.path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (f < 0) fail(w.path, "reopen the file for the summary");
  w.file = Handle(f, H5Fclose);
  describe_summary(w.file.get(), w.path, summary);
  write_sidecar(w);
  if (!w.file.reset()) fail(w.path, "close the file");
}

namespace {
// A batch's file, its root attributes written: the format, the run's options, the batch's own.
Handle create_batch_file(const std::string& path, const char* format, const BatchConfig& config,
                         const std::string& scene, long steps) {
  Handle file = create_file(path);
  const hid_t f = file.get();
  attribute(f, path, "format", std::string(format));
  describe_run(f, path, config.run, scene, nullptr, steps);
  attribute(f, path, "count", config.count);
  attribute(f, path, "seed", static_cast<long>(config.seed));
  for (const auto& v : config.vary) attribute(f, path, "vary " + v.substr(0, v.find('=')), v);
  for (const auto& a : config.run.assignments) attribute(f, path, "set " + a.substr(0, a.find('=')), a);
  return file;
}
}  // namespace

void write_batch_hdf5(const std::string& path, const BatchConfig& config, const std::string& scene,
                      const BatchResult& result, long steps) {
  const Quiet quiet;
  Handle file = create_batch_file(path, "nonholo batch", config, scene, steps);
  const hid_t f = file.get();

  // The CSV's columns, in its order and with its names.
  const auto& rows = result.rows;
  auto column = [&](const std::string& name, auto value) {
    std::vector<double> c(rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) c[i] = value(rows[i]);
    write_column(f, path, name, c);
  };
  std::vector<std::int64_t> index(rows.size()), restarts(rows.size());
  std::vector<std::string> status(rows.size()), messages(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    index[i] = static_cast<std::int64_t>(i);
    restarts[i] = rows[i].summary.restarts;
    status[i] = to_string(rows[i].summary.status);
    messages[i] = rows[i].summary.message;
  }
  using Row = BatchResult::Trajectory;
  write_column(f, path, "trajectory", index);
  for (std::size_t v = 0; v < result.varied.size(); ++v) column(result.varied[v], [v](const Row& r) { return r.values[v]; });
  column("t_final", [](const Row& r) { return r.summary.t_final; });
  for (std::size_t c = 0; c < result.shown.size(); ++c) column(result.shown[c], [c](const Row& r) { return r.final_q[c]; });
  column("energy_rel_err_max", [](const Row& r) { return r.summary.energy_rel_err_max; });
  column("energy_post_rel_err_max", [](const Row& r) { return r.summary.energy_post_rel_err_max; });
  column("residual_max", [](const Row& r) { return r.summary.residual_max; });
  column("gap_max", [](const Row& r) { return r.summary.gap_max; });
  write_column(f, path, "restarts", restarts);
  column("parasitic_max", [](const Row& r) { return r.summary.parasitic_max; });
  if (result.aggregate.has_work) {
    column("work", [](const Row& r) { return r.summary.has_work ? r.summary.work : std::nan(""); });
    column("energy_balance_err_max", [](const Row& r) { return r.summary.energy_balance_err_max; });
  }
  if (config.run.error_estimate) column("error_estimate", [](const Row& r) { return r.summary.error_estimate; });
  write_column(f, path, "status", status);
  write_column(f, path, "messages", messages);

  describe_summary(f, path, result.aggregate);
  Handle g = group(f, path, "batch");
  attribute(g.get(), path, "trajectories", result.trajectories);
  attribute(g.get(), path, "threads", static_cast<long>(result.threads));
  attribute(g.get(), path, "ranks", static_cast<long>(result.ranks));  // MPI processes (1 without mpirun)
  attribute(g.get(), path, "failed", result.failed);
  attribute(g.get(), path, "first_failure", result.first_failure);
  g.reset();
  if (!file.reset()) fail(path, "close the file");
}

// A 2-D dataset of rows x columns doubles, written at once.
namespace {
void write_matrix(hid_t file, const std::string& path, const char* name, const std::vector<double>& values,
                  hsize_t rows, hsize_t columns) {
  const hsize_t dims[2] = {rows, columns};
  Handle space = check(H5Screate_simple(2, dims, nullptr), H5Sclose, path, std::string("make the space of ") + name);
  Handle d = check(H5Dcreate2(file, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                   H5Dclose, path, std::string("create ") + name);
  if (rows * columns > 0)
    check(H5Dwrite(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), path,
          std::string("write ") + name);
}
}  // namespace

void write_batch_states(const std::string& path, const BatchConfig& config, const std::string& scene,
                        const BatchResult& result, long steps) {
  const Quiet quiet;
  Handle file = create_batch_file(path, "nonholo batch states", config, scene, steps);
  const hid_t f = file.get();
  const auto& s = result.states;
  const hsize_t count = result.rows.size();
  write_matrix(f, path, "q", s.q, count, s.coordinates.size());
  write_matrix(f, path, "p", s.p, count, s.velocities.size());
  std::vector<std::int64_t> index(count);
  std::vector<std::string> status(count);
  for (std::size_t i = 0; i < count; ++i) {
    index[i] = static_cast<std::int64_t>(i);
    status[i] = to_string(result.rows[i].summary.status);
  }
  write_column(f, path, "trajectory", index);
  write_column(f, path, "status", status);
  write_column(f, path, "coordinates", s.coordinates);
  write_column(f, path, "velocities", s.velocities);
  if (!file.reset()) fail(path, "close the file");
}

}  // namespace nonholo::scenarios
