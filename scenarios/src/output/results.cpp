// A run's output file read back (results.hpp): CSV here, HDF5 in results_hdf5.cpp.
#include <nonholo/scenarios/results.hpp>

#include <charconv>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace nonholo::scenarios {

RunData load_run_hdf5(const std::string& path);  // results_hdf5.cpp (or hdf5_missing.cpp)

namespace {

bool ends_with(const std::string& s, const char* e) {
  const std::string end(e);
  return s.size() > end.size() && s.compare(s.size() - end.size(), end.size(), end) == 0;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::istringstream in(line);
  for (std::string cell; std::getline(in, cell, ',');) cells.push_back(cell);
  return cells;
}

RunData load_run_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("cannot read '" + path + "'");
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> header = split(line);
  const std::size_t n = header.size();
  if (n < 5 || header[0] != "t" || header[n - 3] != "energy" || header[n - 2] != "energy_post" ||
      header[n - 1] != "residual")
    throw std::invalid_argument("'" + path + "' is not a run's CSV output (header t, coordinates, energy, energy_post, residual)");
  RunData d;
  d.coordinates.assign(header.begin() + 1, header.end() - 3);
  d.velocities = d.coordinates;
  std::vector<std::vector<double>> rows;
  for (long row = 2; std::getline(in, line); ++row) {
    const std::vector<std::string> cells = split(line);
    if (cells.size() != n)
      throw std::invalid_argument("'" + path + "' line " + std::to_string(row) + ": " + std::to_string(cells.size()) +
                                  " fields where the header has " + std::to_string(n));
    std::vector<double> values(n);
    for (std::size_t c = 0; c < n; ++c) {
      const auto* begin = cells[c].data();
      const auto result = std::from_chars(begin, begin + cells[c].size(), values[c]);
      if (result.ec != std::errc() || result.ptr != begin + cells[c].size())
        throw std::invalid_argument("'" + path + "' line " + std::to_string(row) + ": '" + cells[c] + "' is not a number");
    }
    rows.push_back(std::move(values));
  }
  const auto frames = static_cast<Eigen::Index>(rows.size()), nq = static_cast<Eigen::Index>(d.coordinates.size());
  d.t.resize(frames), d.q.resize(frames, nq), d.energy.resize(frames), d.energy_post.resize(frames), d.residual.resize(frames);
  for (Eigen::Index k = 0; k < frames; ++k) {
    const auto& r = rows[static_cast<std::size_t>(k)];
    d.t[k] = r[0];
    for (Eigen::Index c = 0; c < nq; ++c) d.q(k, c) = r[static_cast<std::size_t>(c + 1)];
    d.energy[k] = r[n - 3], d.energy_post[k] = r[n - 2], d.residual[k] = r[n - 1];
  }
  return d;
}

}  // namespace

RunData load_run(const std::string& path) {
  if (ends_with(path, ".csv")) return load_run_csv(path);
  if (ends_with(path, ".h5") || ends_with(path, ".hdf5")) return load_run_hdf5(path);
  throw std::invalid_argument("'" + path + "': expected a run's .csv, .h5 or .hdf5 output");
}

}  // namespace nonholo::scenarios
