#pragma once
/// @file
/// A run's output file read back (the C++ side of nonholo.load): the CSV or HDF5 that
/// `nonholo run --out` wrote, as numbers, bit for bit. An HDF5 file also gives p, gap and the
/// summary's attributes; a CSV has none of those (p and gap empty, summary empty).
#include <nonholo/types.hpp>

#include <map>
#include <string>
#include <vector>

namespace nonholo::scenarios {

/// A run's output file, as load_run() reads it.
struct RunData {
  /// The names of q's and p's columns.
  ///@{
  std::vector<std::string> coordinates, velocities;
  ///@}
  Vector t;                        ///< frames
  /// frames x coordinates, frames x velocities (p: HDF5 only)
  ///@{
  Eigen::MatrixXd q, p;
  ///@}
  /// The diagnostics of each frame (Diagnostics); gap: HDF5 only.
  ///@{
  Vector energy, energy_post, residual, gap;
  ///@}
  std::map<std::string, double> summary;        ///< the summary's numbers (HDF5 only)
  std::map<std::string, std::string> summary_text;  ///< ... and its texts (status, message, ...)
};

/// Throws std::invalid_argument naming the path: not readable, not .csv/.h5/.hdf5, not a run's
/// output (a batch's or a checkpoint is refused), or HDF5 not built in. A run killed while
/// writing its HDF5 file is read as far as its last flush.
RunData load_run(const std::string& path);

}  // namespace nonholo::scenarios
