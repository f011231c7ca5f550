// The batch memory check's figure (batch_bytes_per_trajectory) against what a batch really
// keeps: the growth of the peak resident memory per trajectory between two batch sizes.
#include <nonholo/scenarios/batch.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sys/resource.h>

#include "support/expect_error.hpp"

namespace nonholo {
namespace {

long peak_rss_kb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

TEST(BatchMemory, PeakPerTrajectoryIsTheChecksFigure) {
  scenarios::BatchConfig c;
  c.run.scene = "sleigh";
  c.run.t_end = 0.02;
  c.threads = 1;
  c.vary = {"v0=0.5:1.5"};
  c.count = 8000;
  scenarios::run_batch(c);  // the peak of everything but the rows: set-up, allocator, code
  const long before = peak_rss_kb();
  const long more = 32000;
  c.count += more;
  const auto result = scenarios::run_batch(c);
  ASSERT_EQ(result.failed, 0);
  const double measured = static_cast<double>(peak_rss_kb() - before) * 1024.0 / static_cast<double>(more);
  const double figure = scenarios::batch_bytes_per_trajectory(1, false);
  // The figure counts every block a row keeps (no message or warning here, and the strings of
  // a sleigh's summary fit their inline buffers); pages and the allocator's top chunk round the
  // peak by a few pages in 20 MB. Before the rows stopped keeping their whole final state and
  // names, and a copy of the table, a row took 1.3 kB against a figure of 592 bytes.
  EXPECT_GT(measured, 0.9 * figure) << "figure " << figure;
  EXPECT_LT(measured, 1.15 * figure) << "figure " << figure;
}

TEST(BatchMemory, ACountBeyondTheMachineIsRefusedWithTheFigure) {
  scenarios::BatchConfig c;
  c.run.scene = "sleigh";
  c.count = 1000000000000;
  testing::expect_error([&] { scenarios::run_batch(c); },
                        "--count 1000000000000: the results table would need ");
  std::ostringstream figure;
  figure.precision(3);
  figure << "(at least " << scenarios::batch_bytes_per_trajectory(0, false) << " bytes per trajectory)";
  testing::expect_error([&] { scenarios::run_batch(c); }, figure.str());
}

}  // namespace
}  // namespace nonholo
