// The batch's table as CSV and the journal of finished rows (batch_table.hpp).
#include "output/batch_table.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace nonholo::scenarios {
namespace {

std::string number(double x) {
  char buf[32];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, x).ptr);
}

// The batch table's CSV header and rows (`nonholo batch --out`, and the journal below).
void csv_header(std::ostream& out, const std::vector<std::string>& varied, const std::vector<std::string>& shown,
                bool has_work, bool error_estimate) {
  out << "trajectory";
  for (const auto& name : varied) out << "," << name;
  out << ",t_final";
  for (const auto& name : shown) out << "," << name;
  out << ",energy_rel_err_max,energy_post_rel_err_max,residual_max,gap_max,restarts,parasitic_max";
  if (has_work) out << ",work,energy_balance_err_max";
  if (error_estimate) out << ",error_estimate";
  out << ",status\n";
}

void csv_row(std::ostream& out, long i, const BatchResult::Trajectory& r, bool has_work, bool error_estimate) {
  const RunSummary& s = r.summary;
  out << i;
  for (double x : r.values) out << "," << number(x);
  out << "," << number(s.t_final);
  for (double x : r.final_q) out << "," << number(x);
  out << "," << number(s.energy_rel_err_max) << "," << number(s.energy_post_rel_err_max) << ","
      << number(s.residual_max) << "," << number(s.gap_max) << "," << s.restarts << "," << number(s.parasitic_max);
  if (has_work) out << "," << number(s.has_work ? s.work : NAN) << "," << number(s.energy_balance_err_max);
  if (error_estimate) out << "," << number(s.error_estimate);
  out << "," << to_string(s.status) << "\n";
}

}  // namespace

void write_batch_csv(std::ofstream& out, const std::string& path, const BatchResult& result, bool error_estimate) {
  const bool has_work = result.aggregate.has_work;
  csv_header(out, result.varied, result.shown, has_work, error_estimate);
  for (std::size_t i = 0; i < result.rows.size(); ++i)
    csv_row(out, static_cast<long>(i), result.rows[i], has_work, error_estimate);
  out.close();
  if (!out) throw std::runtime_error("error writing '" + path + "'");
}

Journal::Journal(const std::string& out, const BatchProcesses* processes, bool error_estimate)
    : error_estimate_(error_estimate) {
  if (out.empty()) return;
  path_ = out + (processes && processes->size() > 1 ? ".partial.rank" + std::to_string(processes->rank()) : ".partial") +
          ".csv";
  file_.open(path_);
  if (!file_) throw std::invalid_argument("cannot open '" + path_ + "' for writing: " + std::strerror(errno));
}

void Journal::add(long i, const BatchResult::Trajectory& row, const std::vector<std::string>& varied,
                  const std::vector<std::string>& names) {
  if (path_.empty()) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!header_) {
    has_work_ = row.summary.has_work;
    csv_header(file_, varied,
               std::vector<std::string>(names.begin(), names.begin() + static_cast<std::ptrdiff_t>(row.final_q.size())),
               has_work_, error_estimate_);
    header_ = true;
  }
  std::ostringstream line;  // whole, then one write: a kill leaves no half row
  csv_row(line, i, row, has_work_, error_estimate_);
  file_ << line.str();
  file_.flush();
}

void Journal::remove() {
  if (path_.empty()) return;
  file_.close();
  std::remove(path_.c_str());
}

}  // namespace nonholo::scenarios
