// What a batch keeps per trajectory until it ends (nonholo/scenarios/batch.hpp), and the check
// of a --count against the machine's memory.
#include <nonholo/scenarios/batch.hpp>

#include <unistd.h>

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include "output/batch_row.hpp"

namespace nonholo::scenarios {
namespace {

// The bytes glibc's malloc takes for a request of n (64-bit): n plus its 8-byte size field,
// rounded up to 16, at least 32; nothing for an empty vector or string.
double heap_block(std::size_t n) { return n == 0 ? 0.0 : static_cast<double>(std::max<std::size_t>(32, (n + 8 + 15) / 16 * 16)); }

}  // namespace

double batch_bytes_per_trajectory(std::size_t varied, bool mpi_writer) {
  double bytes = sizeof(BatchResult::Trajectory) + sizeof(std::string)  // the row, its error slot
                 + heap_block(varied * sizeof(double)) + heap_block(3 * sizeof(double));
  if (mpi_writer) {
    // Every row's bytes arrive before any is unpacked: an item each, and a byte in `seen`.
    Row row;
    row.values.assign(varied, 0.0);
    row.final_q = Vector::Zero(3);
    row.names.assign(3, "");
    bytes += sizeof(EnsembleItem) + 1 + heap_block(pack_row(row).size());
  }
  return bytes;
}

void check_batch_memory(const BatchConfig& config) {
  const bool writer = config.processes && config.processes->size() > 1 && config.processes->writes();
  const double row = batch_bytes_per_trajectory(config.vary.size(), writer);
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  const double memory = pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : 0.0;
  const double need = row * static_cast<double>(config.count);
  if (!(memory > 0.0 && need > memory)) return;
  std::ostringstream os;
  os.precision(3);
  os << "--count " << config.count << ": the results table would need " << need / 1e9 << " GB (at least " << row
     << " bytes per trajectory" << (writer ? " on the writing rank" : "") << "); this machine has " << memory / 1e9
     << " GB";
  throw std::invalid_argument(os.str());
}

}  // namespace nonholo::scenarios
