// An ensemble of Chaplygin sleighs over MPI ranks with ensemble_for (nonholo/mpi_ensemble.hpp):
// trajectory i starts turning at 0.5 + i / count; each rank integrates its share on two
// threads (one Workspace per thread, as integrate_batch keeps them), returns the final
// configuration as bytes, and rank 0 gets them all in order.
#include <nonholo/mpi_ensemble.hpp>
#include <nonholo/nonholo.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <vector>

int main(int argc, char** argv) {
  int provided = 0;  // SERIALIZED: the dynamic schedule claims work from any thread
  MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
  using namespace nonholo;
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  b.add_one_form({0, 1, 2});
  b.one_form_values([](ConstVecRef q, VecRef mu) { mu << std::sin(q[2]), -std::cos(q[2]), 0.2; });
  const Model model = b.build();

  EnsembleOptions options;
  options.threads = 2;
  std::vector<std::unique_ptr<Workspace>> workspaces(2);
  const long count = 64;
  const auto items = ensemble_for(
      MPI_COMM_WORLD, count,
      [&](long i, int thread) {
        auto& ws = workspaces[static_cast<std::size_t>(thread)];
        if (!ws) ws = std::make_unique<Workspace>(model);
        Vector v(3);
        v << 1.0, 0.0, 0.5 + static_cast<double>(i) / count;
        State s = start_from_velocity(model, *ws, 0.0, Vector::Zero(3), v);
        for (int k = 0; k < 1000; ++k)
          if (step(model, *ws, s, RattleOptions{0.01}) != Status::Ok) throw std::runtime_error(ws->message());
        return std::string(reinterpret_cast<const char*>(s.q.data()), 3 * sizeof(double));
      },
      options);

  int rank = 0, failed = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  for (std::size_t i = 0; i < items.size(); ++i) {  // empty but on rank 0
    if (!items[i].error.empty()) {
      std::fprintf(stderr, "trajectory %zu: %s\n", i, items[i].error.c_str());
      failed = 1;
      continue;
    }
    double q[3];
    std::memcpy(q, items[i].data.data(), sizeof q);
    if (i % 16 == 0) std::printf("trajectory %zu: x=%.6f y=%.6f theta=%.6f\n", i, q[0], q[1], q[2]);
  }
  MPI_Finalize();
  return failed;
}
