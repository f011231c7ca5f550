// ensemble_for (nonholo/mpi_ensemble.hpp): jobs over the ranks of a duplicated communicator, in static shares
// or claimed in chunks from a counter on the root, threads within each rank, items gathered on the root.
#include <nonholo/mpi_ensemble.hpp>

#include <nonholo/batch.hpp>

#include <omp.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "claim_counter.hpp"
#include "gather.hpp"

namespace nonholo {
namespace {

using detail::DoneJob;

// The caller's communicator, duplicated for one call and freed on every way out.
class OwnComm {
 public:
  explicit OwnComm(MPI_Comm user) { MPI_Comm_dup(user, &comm_); }
  ~OwnComm() { MPI_Comm_free(&comm_); }
  OwnComm(const OwnComm&) = delete;
  OwnComm& operator=(const OwnComm&) = delete;
  MPI_Comm get() const { return comm_; }

 private:
  MPI_Comm comm_ = MPI_COMM_NULL;
};

// Arguments every rank checks alike, before any message (so that all throw or none does:
// hence the options' threads, not the cores each rank has).
void check(MPI_Comm comm, long count, const EnsembleOptions& o) {
  int size = 0;
  MPI_Comm_size(comm, &size);
  if (count < 0) throw std::invalid_argument("ensemble_for: count " + std::to_string(count) + " must not be negative");
  if (o.threads < 0) throw std::invalid_argument("ensemble_for: threads " + std::to_string(o.threads) + " must not be negative");
  if (o.chunk < 0) throw std::invalid_argument("ensemble_for: chunk " + std::to_string(o.chunk) + " must not be negative");
  if (o.root < 0 || o.root >= size)
    throw std::invalid_argument("ensemble_for: root " + std::to_string(o.root) + " is not a rank of the communicator (" +
                                std::to_string(size) + " ranks)");
  int level = MPI_THREAD_SINGLE;
  MPI_Query_thread(&level);
  if (o.schedule == EnsembleSchedule::Dynamic && o.threads != 1 && level < MPI_THREAD_SERIALIZED)
    throw std::invalid_argument("ensemble_for: the dynamic schedule with more than one thread per rank claims "
                                "work from any thread: initialise MPI with MPI_Init_thread(..., "
                                "MPI_THREAD_SERIALIZED, ...), or use one thread or the static schedule");
}

// Rank r of P runs [count r / P, count (r + 1) / P), its threads as parallel_for does.
std::vector<DoneJob> run_static(MPI_Comm comm, long count, int threads, const EnsembleJob& job) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  const long first = count * rank / size, last = count * (rank + 1) / size;
  std::vector<DoneJob> done(static_cast<std::size_t>(last - first));
  const auto errors = parallel_for(last - first, threads, [&](long k, int thread) {
    DoneJob& d = done[static_cast<std::size_t>(k)];
    d.index = first + k;  // set before the job, which may throw
    d.item.data = job(first + k, thread);
  });
  for (std::size_t k = 0; k < done.size(); ++k) done[k].item.error = errors[k];
  return done;
}

// Every thread of every rank claims `chunk` indices at a time from the counter on the root
// until they run out: a rank that drew cheap jobs simply claims more.
std::vector<DoneJob> run_dynamic(MPI_Comm comm, int root, long count, long chunk, int threads, const EnsembleJob& job) {
  detail::ClaimCounter counter(comm, root);
  std::vector<std::vector<DoneJob>> by_thread(static_cast<std::size_t>(threads));
#pragma omp parallel num_threads(threads)
  {
    const int thread = omp_get_thread_num();
    auto& mine = by_thread[static_cast<std::size_t>(thread)];
    for (;;) {
      long first = 0;
#pragma omp critical(nonholo_ensemble_claim)
      first = counter.claim(chunk);
      if (first >= count) break;
      for (long i = first; i < std::min(count, first + chunk); ++i) {
        DoneJob d{i, {}};
        d.item.error = capture_error([&] { d.item.data = job(i, thread); });
        mine.push_back(std::move(d));
      }
    }
  }
  std::vector<DoneJob> done;
  for (auto& part : by_thread)
    for (DoneJob& d : part) done.push_back(std::move(d));
  return done;
}

}  // namespace

std::vector<EnsembleItem> ensemble_for(MPI_Comm user, long count, const EnsembleJob& job, const EnsembleOptions& options) {
  check(user, count, options);
  const int threads = batch_threads(options.threads);
  const OwnComm comm(user);
  int size = 1;
  MPI_Comm_size(comm.get(), &size);
  // As parallel_for: about 64 claims per thread, so that the last ones are short.
  const long chunk = options.chunk > 0 ? options.chunk : std::max(1L, count / (64L * threads * size));
  std::vector<DoneJob> done = options.schedule == EnsembleSchedule::Static
                                  ? run_static(comm.get(), count, threads, job)
                                  : run_dynamic(comm.get(), options.root, count, chunk, threads, job);
  return detail::gather_items(comm.get(), options.root, count, std::move(done));
}

}  // namespace nonholo
