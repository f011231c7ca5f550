#pragma once
// Two runs' summaries equal in every value but the timings, bit for bit (a resumed run against
// the uninterrupted one, a model's run against its scene's).
#include <nonholo/scenarios/run_types.hpp>

#include <gtest/gtest.h>

#include <cstring>
#include <string>

namespace nonholo::testing {

inline void expect_same_summary(const scenarios::RunSummary& a, const scenarios::RunSummary& b,
                                const std::string& label) {
  using scenarios::SummaryField;
  const auto fa = a.fields(), fb = b.fields();
  ASSERT_EQ(fa.size(), fb.size()) << label << "\n" << a.line() << "\n" << b.line();
  for (std::size_t i = 0; i < fa.size(); ++i) {
    const SummaryField &x = fa[i], &y = fb[i];
    EXPECT_EQ(x.key, y.key) << label;
    if (x.key == "wall_s" || x.key == "setup_s" || x.key == "ns_per_step" || x.key == "ns_per_body_step") continue;
    EXPECT_EQ(std::memcmp(&x.number, &y.number, sizeof(double)), 0)
        << label << ": " << x.key << " " << x.number << " against " << y.number;
    EXPECT_EQ(x.integer, y.integer) << label << ": " << x.key;
    EXPECT_EQ(x.text, y.text) << label << ": " << x.key;
  }
  EXPECT_EQ(a.message, b.message) << label;
  EXPECT_EQ(a.warning, b.warning) << label;
}

}  // namespace nonholo::testing
