// Every bad input to the model builder gets a precise exception message.
#include <nonholo/model_builder.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "support/expect_error.hpp"

namespace nonholo {
namespace {

using testing::expect_error;

const OneFormValues kUnit = [](ConstVecRef, VecRef mu) { mu.setOnes(); };

TEST(ModelBuilder, BuildsAValidModel) {
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 2.0, 0.5);
  b.add_body({"z"}, Eigen::Matrix<double, 1, 1>(3.0));
  b.add_one_form({0, 1, 2});
  b.add_one_form({3});
  b.one_form_values(kUnit);
  const Model m = b.build();
  EXPECT_EQ(m.num_coordinates(), 4);
  EXPECT_EQ(m.num_bodies(), 2);
  EXPECT_EQ(m.num_one_forms(), 2);
  EXPECT_EQ(m.num_one_form_values(), 4);
  EXPECT_EQ(m.coordinate_names()[3], "z");
  EXPECT_EQ(m.body(1).offset, 3);
  EXPECT_DOUBLE_EQ(m.inverse_mass().entry(0, 0), 0.5);
  EXPECT_DOUBLE_EQ(m.inverse_mass().entry(2, 2), 2.0);
  EXPECT_FALSE(m.has_applied_force());
}

TEST(ModelBuilder, RejectsBadMassBlocks) {
  expect_error([] { ModelBuilder().add_body({"x", "y"}, Eigen::MatrixXd::Identity(3, 2)); },
               "body 0 (x, y): mass block is 3x2, expected 2x2 (one row and column per coordinate)");
  expect_error([] { ModelBuilder().add_body({"x", "y", "z"}, Eigen::MatrixXd::Identity(2, 2)); },
               "mass block is 2x2, expected 3x3");
  expect_error([] { ModelBuilder().add_body({}, Eigen::MatrixXd(0, 0)); }, "body 0 has no coordinates");
  expect_error(
      [] {
        Eigen::Matrix2d m = Eigen::Matrix2d::Identity();
        m(0, 1) = m(1, 0) = NAN;
        ModelBuilder().add_body({"x", "y"}, m);
      },
      "body 0 (x, y): mass block entry (0, 1) is nan");
  expect_error([] { ModelBuilder().add_body({"x"}, Eigen::Matrix<double, 1, 1>(INFINITY)); },
               "entry (0, 0) is inf");
  expect_error([] { ModelBuilder().add_body({"x"}, Eigen::Matrix<double, 1, 1>(0.0)); },
               "mass block entry (0, 0) for x is 0; a mass or moment of inertia must be positive");
  expect_error([] { ModelBuilder().add_body({"x"}, Eigen::Matrix<double, 1, 1>(-2.0)); },
               "for x is -2; a mass or moment of inertia must be positive");
  expect_error(
      [] {
        Eigen::Matrix2d m;
        m << 1.0, 0.5, 0.4, 1.0;
        ModelBuilder().add_body({"x", "y"}, m);
      },
      "mass block is not symmetric: M(1, 0) = 0.40000000000000002 but M(0, 1) = 0.5");
  expect_error(
      [] {
        Eigen::Matrix2d m;
        m << 1.0, 2.0, 2.0, 1.0;
        ModelBuilder().add_body({"x", "y"}, m);
      },
      "mass block is not positive definite (smallest eigenvalue -1)");
}

TEST(ModelBuilder, RejectsBadPlanarBodies) {
  expect_error([] { ModelBuilder().add_planar_body({"x", "y", "theta"}, -1.0, 1.0); },
               "body 0 (x, y, theta): mass m = -1 must be positive and finite");
  expect_error([] { ModelBuilder().add_planar_body({"x", "y", "theta"}, 0.0, 1.0); },
               "mass m = 0 must be positive");
  expect_error([] { ModelBuilder().add_planar_body({"x", "y", "theta"}, 1.0, NAN); },
               "moment of inertia I = nan must be positive and finite");
}

TEST(ModelBuilder, RejectsBadCoordinateNames) {
  expect_error(
      [] {
        ModelBuilder b;
        b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
        b.add_planar_body({"x", "y1", "theta1"}, 1.0, 1.0);
      },
      "coordinate name 'x' is used by body 0 and by body 1 (x, y1, theta1)");
  expect_error([] { ModelBuilder().add_body({"x", "x"}, Eigen::Matrix2d::Identity()); },
               "coordinate name 'x' appears twice");
  expect_error([] { ModelBuilder().add_body({"x", ""}, Eigen::Matrix2d::Identity()); },
               "coordinate 1 has an empty name");
}

TEST(ModelBuilder, RejectsBadOneFormRows) {
  auto with_row = [](std::vector<int> cols) {
    return [cols] {
      ModelBuilder b;
      b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
      b.add_one_form({0});
      b.add_one_form(cols);
      b.one_form_values(kUnit);
      b.build();
    };
  };
  expect_error(with_row({}), "one-form row 1 has no columns (an empty row constrains nothing)");
  expect_error(with_row({0, 3}),
               "one-form row 1: column 3 is out of range (the model has 3 coordinates, columns 0 to 2)");
  expect_error(with_row({-1}), "one-form row 1: column -1 is out of range");
  expect_error(with_row({2, 0, 2}), "one-form row 1: column 2 (theta) appears twice");
}

TEST(ModelBuilder, RejectsIncompleteModels) {
  expect_error([] { ModelBuilder().build(); }, "the model has no bodies");
  expect_error(
      [] {
        ModelBuilder b;
        b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
        b.add_one_form({0, 1});
        b.add_one_form({2});
        b.build();
      },
      "the model has 2 one-form rows but no value function (call one_form_values)");
  expect_error([] { ModelBuilder().potential([](ConstVecRef) { return 0.0; }, nullptr); },
               "potential: give both the value and its gradient, or neither");
  expect_error([] { ModelBuilder().one_form_values(nullptr); }, "the value function is empty");
  expect_error(
      [] {
        ModelBuilder b;
        const MomentumMap j = [](ConstVecRef, ConstVecRef p) { return p[0]; };
        b.momentum_map("px", j);
        b.momentum_map("px", j);
      },
      "momentum_map 'px' is defined twice");
}

TEST(ModelBuilder, AcceptsAModelWithoutOneForms) {
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  const Model m = b.build();
  EXPECT_EQ(m.num_one_forms(), 0);
  EXPECT_EQ(m.gram().pattern().size, 0);
}

// The name table grows past its first sizes and still finds the owner of a name; building
// from an lvalue twice, or from an rvalue (moved, the builder left empty), gives one model.
TEST(ModelBuilder, ManyBodiesAndBothWaysToBuild) {
  ModelBuilder b;
  for (int i = 0; i < 2000; ++i) {
    const std::string s = std::to_string(i);
    b.add_planar_body({"x" + s, "y" + s, "theta" + s}, 1.0 + i, 2.0);
  }
  testing::expect_error([&] { b.add_planar_body({"u", "y1234", "v"}, 1.0, 1.0); },
                        "coordinate name 'y1234' is used by body 1234 and by body 2000 (u, y1234, v)");
  for (int i = 0; i < 2000; ++i) b.add_knife_edge({i, 0.1 * i});
  const Model a = b.build(), c = b.build();
  const Model m = std::move(b).build();
  for (const Model* x : {&c, &m}) {
    EXPECT_EQ(x->num_coordinates(), 6000);
    EXPECT_EQ(x->num_one_forms(), 2000);
    EXPECT_EQ(x->one_form_pattern().col_idx, a.one_form_pattern().col_idx);
    EXPECT_EQ(x->coordinate_names(), a.coordinate_names());
    EXPECT_TRUE(x->is_chain());
  }
  testing::expect_error([&] { b.build(); }, "the model has no bodies");  // moved from: empty
}

// Names are found whichever way they are kept: numbered ("<prefix><n>", by number; pages far
// apart; the empty prefix) or hashed (no trailing number, a leading zero, 9 digits; the table
// grows). Names that differ only in those details are different names.
TEST(ModelBuilder, EveryKindOfNameIsFoundAgain) {
  ModelBuilder b;
  const std::vector<std::string> kinds = {"x7", "x07", "x", "7", "07", "x99999999", "x123456789", "y7z", "x7 "};
  for (std::size_t i = 0; i < kinds.size(); ++i) b.add_body({kinds[i]}, Eigen::Matrix<double, 1, 1>(1.0));
  for (int i = 0; i < 3000; ++i) b.add_body({"w" + std::to_string(i) + "_"}, Eigen::Matrix<double, 1, 1>(1.0));
  for (std::size_t i = 0; i < kinds.size(); ++i)
    testing::expect_error([&] { b.add_body({"fresh", kinds[i]}, Eigen::Matrix2d::Identity()); },
                          "coordinate name '" + kinds[i] + "' is used by body " + std::to_string(i) + " and");
  testing::expect_error([&] { b.add_body({"w2999_"}, Eigen::Matrix<double, 1, 1>(1.0)); },
                        "coordinate name 'w2999_' is used by body " + std::to_string(kinds.size() + 2999));
  for (const char* fresh : {"x8", "x6", "x70", "x007", "8", "x99999998", "x1234567890", "y8z", "w3000_"})
    b.add_body({fresh}, Eigen::Matrix<double, 1, 1>(1.0));
  EXPECT_EQ(b.build().num_coordinates(), static_cast<int>(2 * kinds.size()) + 3000);
}

// The model keeps its names packed and makes the lists of strings on first use: every name reads
// back as given (short, long, numbered), one by one or as the lists, from copies too, and threads
// asking for the list at once all get the same one.
TEST(ModelBuilder, NamesReadBackPackedAndAsLists) {
  ModelBuilder b;
  const std::string longer = "a coordinate name longer than a short string's buffer";
  b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  b.add_body({longer, "z1"}, Eigen::Matrix2d::Identity());
  for (int k = 0; k < 50; ++k)
    b.add_planar_body({"x" + std::to_string(k + 10), "y" + std::to_string(k + 10), "t" + std::to_string(k + 10)},
                      1.0, 1.0);
  // Runs broken: numbers that differ within a body, a leading zero, a gap, a new run after it.
  const std::vector<std::vector<std::string>> odd{
      {"x60", "y60", "t61"}, {"x07", "y07", "t07"}, {"x70", "y70", "t70"}, {"x71", "y71", "t71"}, {"7", "8", "9"}};
  for (const auto& names : odd) b.add_planar_body({names[0], names[1], names[2]}, 1.0, 1.0);
  b.add_one_form({0, 1, 2});
  b.one_form_values(kUnit);
  const Model m = b.build();
  std::vector<std::string> expected{"x", "y", "theta", longer, "z1"};
  for (int k = 0; k < 50; ++k)
    for (const char* stem : {"x", "y", "t"}) expected.push_back(stem + std::to_string(k + 10));
  for (const auto& names : odd) expected.insert(expected.end(), names.begin(), names.end());
  ASSERT_EQ(m.num_configuration(), static_cast<int>(expected.size()));
  for (int i = 0; i < m.num_configuration(); ++i) {
    EXPECT_EQ(m.coordinate_name(i), expected[static_cast<std::size_t>(i)]);
    EXPECT_EQ(m.velocity_name(i), expected[static_cast<std::size_t>(i)]);
  }
  const Model copy = m;  // NOLINT: a copy on purpose
  std::vector<const std::vector<std::string>*> seen(4, nullptr);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < seen.size(); ++t) threads.emplace_back([&, t] { seen[t] = &copy.coordinate_names(); });
  for (auto& t : threads) t.join();
  for (const auto* list : seen) EXPECT_EQ(list, seen[0]);
  EXPECT_EQ(*seen[0], expected);
  EXPECT_EQ(m.coordinate_names(), expected);
  EXPECT_EQ(m.velocity_names(), expected);
}

// Velocity names and row labels are kept packed (NameStore) too: read back one by one and as
// a list, on a model whose planar bodies come before and after rigid ones (velocity names then
// differ from coordinate names), with labelled and unlabelled rows mixed.
TEST(ModelBuilder, VelocityNamesAndRowLabelsReadBackPacked) {
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  b.add_planar_body({"x1", "y1", "t1"}, 1.0, 1.0);
  RigidBody ball;
  ball.translation = 2;
  ball.inertia = Eigen::Matrix3d::Identity() * 0.4;
  b.add_rigid_body(ball);  // body 2: wx2 wy2 wz2 vx2 vy2
  ball.name = "B";
  b.add_rigid_body(ball);  // body 3: wxB ... vyB
  b.add_planar_body({"x4", "y4", "t4"}, 1.0, 1.0);
  b.add_one_form({0, 1, 2});
  b.add_one_form({3, 4, 5}, "a label longer than a short string's buffer");
  b.add_one_form({6, 7, 8});
  b.add_one_form({9, 10}, "short");
  b.add_one_form({14, 15, 16});
  b.one_form_values(kUnit);
  const Model m = b.build();
  const std::vector<std::string> expected{"x",   "y",   "theta", "x1",  "y1",  "t1",  "wx2", "wy2", "wz2",
                                          "vx2", "vy2", "wxB",   "wyB", "wzB", "vxB", "vyB", "x4",  "y4",
                                          "t4"};
  ASSERT_EQ(m.num_velocities(), static_cast<int>(expected.size()));
  for (int i = 0; i < m.num_velocities(); ++i) EXPECT_EQ(m.velocity_name(i), expected[static_cast<std::size_t>(i)]);
  EXPECT_EQ(m.velocity_names(), expected);
  EXPECT_EQ(m.coordinate_name(6), "qw2");
  const std::vector<std::string> labels{"", "a label longer than a short string's buffer", "", "short", ""};
  for (int r = 0; r < m.num_one_forms(); ++r) {
    EXPECT_EQ(m.row_label(r), labels[static_cast<std::size_t>(r)]);
    EXPECT_EQ(m.row_label_view(r), labels[static_cast<std::size_t>(r)]);
  }
  EXPECT_EQ(m.row_label(-1), "");
  EXPECT_EQ(m.row_label(m.num_one_forms()), "");
  EXPECT_EQ(m.describe_row(3), "one-form row 3 (short)");
}

}  // namespace
}  // namespace nonholo
