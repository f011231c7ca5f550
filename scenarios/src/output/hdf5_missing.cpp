// HDF5 output when nonholo was built without HDF5 (NONHOLO_WITH_HDF5=OFF): asking for it is a
// clear error at set-up, never a CSV in disguise.
#include "output/checkpoint/checkpoint_file.hpp"
#include "output/hdf5_output.hpp"

#include <nonholo/scenarios/results.hpp>

#include <stdexcept>

namespace nonholo::scenarios {

namespace {
[[noreturn]] void missing(const std::string& path) {
  throw std::invalid_argument("--out " + path +
                              ": this nonholo was built without HDF5 (install libhdf5-dev, Debian, and rebuild; "
                              "or write CSV)");
}
}  // namespace

struct Hdf5RunWriter::Impl {};

Hdf5RunWriter::Hdf5RunWriter(const std::string& path, const RunConfig&, const std::string&, const Parameters&, long,
                             const std::string&) {
  missing(path);
}
Hdf5RunWriter::Hdf5RunWriter(const std::string& path, long, const std::string&) { missing(path); }
Hdf5RunWriter::~Hdf5RunWriter() = default;
long Hdf5RunWriter::flush_to_disk() { return 0; }
void Hdf5RunWriter::begin(const std::vector<std::string>&) {}
void Hdf5RunWriter::velocities(const std::vector<std::string>&) {}
void Hdf5RunWriter::frame(double, ConstVecRef, ConstVecRef, const Diagnostics&) {}
void Hdf5RunWriter::end() {}
void Hdf5RunWriter::finish(const RunSummary&) {}

void write_checkpoint(const std::string& path, const CheckpointInfo&, const std::string&, ConstVecRef, ConstVecRef,
                      FileLock*) {
  throw std::invalid_argument("--checkpoint " + path +
                              ": this nonholo was built without HDF5, which checkpoints need (install libhdf5-dev, "
                              "Debian, and rebuild)");
}
std::string read_checkpoint(const std::string& path, CheckpointInfo*) {
  throw std::invalid_argument("--resume " + path +
                              ": this nonholo was built without HDF5, which checkpoints need (install libhdf5-dev, "
                              "Debian, and rebuild)");
}

void write_batch_states(const std::string& path, const BatchConfig&, const std::string&, const BatchResult&, long) {
  missing(path);
}

RunData load_run_hdf5(const std::string& path) {
  throw std::invalid_argument("'" + path + "': this nonholo was built without HDF5 (install libhdf5-dev, Debian, and rebuild)");
}

void write_batch_hdf5(const std::string& path, const BatchConfig&, const std::string&, const BatchResult&, long) {
  missing(path);
}

}  // namespace nonholo::scenarios
