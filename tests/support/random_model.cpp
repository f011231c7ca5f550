// Random models for cross-checks (random_model.hpp).
#include "support/random_model.hpp"

#include <nonholo/model_builder.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>

namespace nonholo::testing {

Vector random_vector(std::uint32_t seed, int n, double scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-scale, scale);
  Vector v(n);
  for (int i = 0; i < n; ++i) v[i] = u(rng);
  return v;
}

Model random_model(std::uint32_t seed, const RandomModelOptions& o) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> size_of_body(1, 3);
  ModelBuilder b;
  std::vector<int> offset;
  int n = 0;
  for (int k = 0; k < o.bodies; ++k) {
    const int size = size_of_body(rng);
    Eigen::MatrixXd a = Eigen::MatrixXd::NullaryExpr(size, size, [&] { return u(rng); });
    Eigen::MatrixXd mass = a * a.transpose() + Eigen::MatrixXd::Identity(size, size);
    if (k % 2 == 0) {
      const Eigen::MatrixXd diagonal = mass.diagonal().asDiagonal();
      mass = diagonal;
    }
    std::vector<std::string> names;
    for (int i = 0; i < size; ++i) names.push_back("b" + std::to_string(k) + "q" + std::to_string(i));
    offset.push_back(n);
    b.add_body(names, mass);
    n += size;
  }
  if (o.rows > n) throw std::invalid_argument("random_model: more rows than coordinates");

  // Row r: value_k(q) = c_k + d_k sin(q[j_k] + e_k) for a random coordinate j_k. Each row
  // has its own "home" coordinate (a random injection) with a dominant value, and touches
  // the home's body and one more random body: structurally and numerically independent.
  struct Entry { double c, d, e; int j; };
  auto entries = std::make_shared<std::vector<Entry>>();
  std::vector<int> homes(n);
  for (int i = 0; i < n; ++i) homes[i] = i;
  std::shuffle(homes.begin(), homes.end(), rng);
  std::uniform_int_distribution<int> pick_body(0, o.bodies - 1), pick_coord(0, n - 1);
  auto body_of = [&](int i) {
    int body = 0;
    while (body + 1 < o.bodies && offset[body + 1] <= i) ++body;
    return body;
  };
  for (int r = 0; r < o.rows; ++r) {
    const int home = homes[r];
    std::vector<int> cols{home};
    for (int body : {body_of(home), pick_body(rng)}) {
      const int end = body + 1 < o.bodies ? offset[body + 1] : n;
      for (int i = offset[body]; i < end; ++i)
        if (std::find(cols.begin(), cols.end(), i) == cols.end()) cols.push_back(i);
    }
    b.add_one_form(cols);
    for (std::size_t k = 0; k < cols.size(); ++k)
      entries->push_back({k == 0 ? 3.0 + 0.5 * u(rng) : 0.5 * u(rng), 0.3 * u(rng), u(rng), pick_coord(rng)});
  }
  b.one_form_values([entries](ConstVecRef q, VecRef mu) {
    for (std::size_t k = 0; k < entries->size(); ++k) {
      const Entry& e = (*entries)[k];
      mu[static_cast<Eigen::Index>(k)] = e.c + e.d * std::sin(q[e.j] + e.e);
    }
  });
  if (o.applied_force) {
    const Vector stiffness = random_vector(seed + 1, n, 1.0).cwiseAbs();
    const Vector drive = random_vector(seed + 2, n, 1.0);
    b.potential(
        [stiffness](ConstVecRef q) {
          return 0.5 * (stiffness.array() * q.array().square()).sum() + 0.1 * std::cos(q.sum());
        },
        [stiffness](ConstVecRef q, VecRef g) {
          g = stiffness.cwiseProduct(q);
          g.array() -= 0.1 * std::sin(q.sum());
        });
    b.external_force([drive](double t, ConstVecRef q, VecRef f) {
      f = drive * std::sin(t) - 0.05 * q;
    });
  }
  Model without_bias = b.build();
  if (!o.analytic_bias) return without_bias;
  // Analytic bias: sum_k d_k cos(q[j_k] + e_k) qdot[j_k] qdot[col_k] over each row.
  const auto pattern = without_bias.one_form_pattern();
  b.one_form_bias([entries, pattern](ConstVecRef q, ConstVecRef v, VecRef bias) {
    for (int r = 0; r < pattern.rows; ++r) {
      double s = 0.0;
      for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k) {
        const Entry& e = (*entries)[static_cast<std::size_t>(k)];
        s += e.d * std::cos(q[e.j] + e.e) * v[e.j] * v[pattern.col_idx[k]];
      }
      bias[r] = s;
    }
  });
  return b.build();
}

}  // namespace nonholo::testing
