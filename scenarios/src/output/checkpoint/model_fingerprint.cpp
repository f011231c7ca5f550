// A model's fingerprint (model_fingerprint.hpp): what a resume compares.
#include "output/checkpoint/model_fingerprint.hpp"

#include <cstddef>
#include <cstdint>
#include <cstdio>

namespace nonholo::scenarios {
namespace {

// FNV-1a over bytes added piece by piece (no copy of a large model's names and masses): the same
// print on every build, where std::hash may differ.
struct Hash {
  std::uint64_t h = 0xcbf29ce484222325ull;
  void add(const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) h = (h ^ bytes[i]) * 0x100000001b3ull;
  }
};

}  // namespace

std::string model_fingerprint(const Model& model) {
  Hash hash;
  for (const int n : {model.num_configuration(), model.num_velocities(), model.num_bodies(), model.num_one_forms(),
                      model.num_one_form_values(), model.num_holonomic()})
    hash.add(&n, sizeof n);
  for (const bool b : {model.has_potential(), model.has_external_force(), model.has_configuration_metric(),
                       model.has_rigid_bodies()})
    hash.add(b ? "1" : "0", 1);
  for (const auto* names : {&model.coordinate_names(), &model.velocity_names()})
    for (const std::string& name : *names) hash.add(name.c_str(), name.size() + 1);  // with its '\0'
  // The inverse masses, through M^-1 applied to (1, 2, ..., n_v): every block's entries count.
  // (Not the implicit form's, whose metric depends on q.)
  if (!model.has_configuration_metric()) {
    const int n = model.num_velocities();
    const Vector ramp = Vector::LinSpaced(n, 1.0, static_cast<double>(n));
    Vector out(n);
    model.inverse_mass().multiply(ramp.data(), out.data());
    hash.add(out.data(), static_cast<std::size_t>(n) * sizeof(double));
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(hash.h));
  return hex;
}

}  // namespace nonholo::scenarios
