#pragma once
// The checkpoint file of `nonholo run --checkpoint FILE.h5`: the run's bytes (archive.hpp, the
// whole loop state, run_checkpoint.hpp) in HDF5 dataset /bytes, beside readable /q and /p and
// root attributes that say what it is (format, format_version, scene, method, t, step). Written
// atomically: to FILE.h5.tmp, flushed to disk (fsync), then renamed over FILE.h5, so that a crash
// mid-write leaves the previous checkpoint whole, and locked (file_lock.hpp) from before the
// rename on, so that no second run takes it up while this one writes it.
#include <nonholo/types.hpp>

#include "output/file_lock.hpp"

#include <string>

namespace nonholo::scenarios {

// Bumped whenever the bytes change meaning: a checkpoint of another format version is refused.
constexpr long kCheckpointFormat = 7;  // 2: RunConfig::threads; 3: RunSummary::setup_s; 4: the accuracy check's
                                       // retries; 5: the run id and the output's identity; 6: the
                                       // accuracy check's companion; 7: the run's source (a model
                                       // built in code, its start time, the model's fingerprint)

struct CheckpointInfo {
  std::string scene, method;
  double t = 0.0;
  long step = 0;
  std::string run_id;  // the run's (LoopState::run_id), also in its HDF5 output: h5py shows both
};

// Throws std::runtime_error (cannot write, HDF5 failure) naming the path; without HDF5,
// std::invalid_argument saying so. `lock` (when given) gets the new file's lock, taken before the
// rename, and lets go of the one it held (the file replaced).
void write_checkpoint(const std::string& path, const CheckpointInfo& info, const std::string& bytes, ConstVecRef q,
                      ConstVecRef p, FileLock* lock = nullptr);
// The bytes; `info` gets the attributes. Throws std::invalid_argument for a missing or unreadable
// file, a file that is not a nonholo checkpoint, or one of another format version.
std::string read_checkpoint(const std::string& path, CheckpointInfo* info = nullptr);

}  // namespace nonholo::scenarios
