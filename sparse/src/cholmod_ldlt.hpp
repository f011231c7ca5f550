#pragma once
// CHOLMOD simplicial LDL^T behind one RAII class: analyse once (in the constructor),
// refactorise numerically on every factorize(), solve with cholmod_solve2 and kept
// workspace. Every CHOLMOD status is mapped to a FactorStatus plus a message. The
// cholmod_common is owned by the object, so one object per thread.
#include <nonholo/sparse/factorization.hpp>

#include <memory>

namespace nonholo::sparse {

enum class CholmodOrdering { Natural, Amd };

class CholmodLDLT final : public Factorization {
 public:
  CholmodLDLT(const SymmetricPattern& pattern, CholmodOrdering ordering);
  ~CholmodLDLT() override;

  FactorStatus factorize(const double* c_values, double min_pivot_ratio) override;
  FactorStatus solve(const double* b, double* x) override;
  double* values_in_place() override;
  const int* slot_positions() const override;
  FactorStatus factorize_in_place(double min_pivot_ratio) override;
  Backend backend() const override {
    return ordering_ == CholmodOrdering::Natural ? Backend::CholmodNatural : Backend::CholmodAmd;
  }

 private:
  struct Impl;  // keeps cholmod.h out of every header
  std::unique_ptr<Impl> impl_;
  CholmodOrdering ordering_;
  FactorStatus from_cholmod(int cholmod_status, const char* call);
};

}  // namespace nonholo::sparse
