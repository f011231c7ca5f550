#pragma once
// HDF5 output of `nonholo run` and `nonholo batch` (--out FILE.h5 or .hdf5), for runs whose CSV
// would be gigabytes of text. A run's file: chunked, compressed datasets /t (frames), /q and /p
// (frames x coordinates), /energy, /energy_post, /residual, /gap, the names in /coordinates,
// and attributes: the scene and the run's options on /, the scene's parameters on
// /parameters, the summary on /summary. A batch's: one dataset per column of its CSV (one row
// per trajectory), the same attributes. The values are the CSV's, bit for bit. The file is
// closed properly after a failed step or Ctrl-C (the run ends normally then). Built with
// HDF5 when found (NONHOLO_WITH_HDF5); without it, opening one throws and says so.
#include <nonholo/scenarios/batch_types.hpp>
#include <nonholo/scenarios/parameters.hpp>
#include <nonholo/scenarios/run_types.hpp>

#include <memory>
#include <string>
#include <vector>

namespace nonholo::scenarios {

// Whether a --out path asks for HDF5 (ends in .h5 or .hdf5).
inline bool is_hdf5_path(const std::string& path) {
  auto ends = [&](const char* e, std::size_t n) { return path.size() > n && path.compare(path.size() - n, n, e) == 0; };
  return ends(".h5", 3) || ends(".hdf5", 5);
}
// Whether an --out path names a CSV file (ends in .csv).
inline bool is_csv_path(const std::string& path) {
  return path.size() > 4 && path.compare(path.size() - 4, 4, ".csv") == 0;
}

class Hdf5RunWriter final : public FrameSink {
 public:
  // Creates the file (throws std::invalid_argument when it cannot, or without HDF5) and
  // writes the attributes known before the run: `config` with the dt and t_end used, `steps`
  // of dt (output intervals for adaptive steps), the run's `run_id`.
  Hdf5RunWriter(const std::string& path, const RunConfig& config, const std::string& scene,
                const Parameters& params, long steps, const std::string& run_id);
  // Continues the file of run `run_id`, resumed from a checkpoint that counted `frames` frames:
  // frames after those are dropped, the summary is written anew by finish(). A file left marked
  // open by a killed run is taken up (the mark cleared, as `h5clear -s` does). Throws
  // std::invalid_argument when the file is missing, unwritable, another run's or holds fewer
  // frames.
  Hdf5RunWriter(const std::string& path, long frames, const std::string& run_id);
  ~Hdf5RunWriter() override;  // closes the file if finish() did not
  void begin(const std::vector<std::string>& coordinates) override;
  void velocities(const std::vector<std::string>& names) override;
  void frame(double t, ConstVecRef q, ConstVecRef p, const Diagnostics& d) override;
  void end() override;  // writes the buffered frames
  // Writes the buffered frames and flushes the file (a checkpoint's moment): the frames so far.
  long flush_to_disk();
  // The summary's attributes, then closes the file; throws std::runtime_error on a write error.
  void finish(const RunSummary& summary);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// The batch's table (BatchResult::rows) as datasets; throws like the writer above.
void write_batch_hdf5(const std::string& path, const BatchConfig& config, const std::string& scene,
                      const BatchResult& result, long steps);
// The batch's final states (`--states FILE.h5`): /q (count x coordinates) and /p (count x
// velocities), /trajectory, /status, the names in /coordinates and /velocities, the run's
// attributes (format "nonholo batch states").
void write_batch_states(const std::string& path, const BatchConfig& config, const std::string& scene,
                        const BatchResult& result, long steps);

}  // namespace nonholo::scenarios
