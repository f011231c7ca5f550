// ensemble_for (nonholo/mpi_ensemble.hpp), run by CTest under `mpirun -n 3`: every index once,
// in order, on the root, whatever the schedule, threads or chunk; a throwing job keeps its
// error and the others run; the caller's communicator sees none of the ensemble's messages;
// any communicator and root work; bad arguments are refused on every rank without a message.
// Every test calls the collectives on every rank, whatever it checks (EXPECT, not ASSERT), so
// that a failure cannot leave the other ranks waiting.
#include <nonholo/mpi_ensemble.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace nonholo {
namespace {

int rank_of(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

int size_of(MPI_Comm comm) {
  int s = 0;
  MPI_Comm_size(comm, &s);
  return s;
}

// A job whose result depends on its index only, of uneven cost.
std::string square(long i, int) {
  double x = 0.0;
  for (long k = 0; k < (i % 5) * 2000; ++k) x += 1e-9 * static_cast<double>(k);
  return std::to_string(i * i) + (x < 0.0 ? "!" : "");
}

// Item i, or an empty one when the vector is too short (and the size check has failed).
EnsembleItem at(const std::vector<EnsembleItem>& items, long i) {
  return i < static_cast<long>(items.size()) ? items[static_cast<std::size_t>(i)] : EnsembleItem{"missing", "missing"};
}

EnsembleOptions options(EnsembleSchedule schedule, int threads, long chunk) {
  EnsembleOptions o;
  o.schedule = schedule;
  o.threads = threads;
  o.chunk = chunk;
  return o;
}

TEST(Ensemble, EveryIndexOnceInOrderOnTheRootWhateverTheSchedule) {
  const long count = 500;
  for (auto schedule : {EnsembleSchedule::Static, EnsembleSchedule::Dynamic})
    for (int threads : {1, 2})
      for (long chunk : {0L, 1L, 7L}) {
        const auto items = ensemble_for(MPI_COMM_WORLD, count, square, options(schedule, threads, chunk));
        if (rank_of(MPI_COMM_WORLD) != 0) {
          EXPECT_TRUE(items.empty());
          continue;
        }
        EXPECT_EQ(items.size(), static_cast<std::size_t>(count));
        for (long i = 0; i < count; ++i) {
          EXPECT_EQ(at(items, i).data, std::to_string(i * i)) << i;
          EXPECT_EQ(at(items, i).error, "") << i;
        }
      }
}

TEST(Ensemble, EveryRankTakesPartInTheStaticSplit) {
  const int ranks = size_of(MPI_COMM_WORLD);
  const auto items = ensemble_for(
      MPI_COMM_WORLD, 2L * ranks, [](long, int) { return std::to_string(rank_of(MPI_COMM_WORLD)); },
      options(EnsembleSchedule::Static, 1, 0));
  if (rank_of(MPI_COMM_WORLD) == 0) {
    for (int i = 0; i < 2 * ranks; ++i) EXPECT_EQ(at(items, i).data, std::to_string(i / 2));
  }
}

TEST(Ensemble, AThrowingJobKeepsItsErrorAndTheOthersRun) {
  for (auto schedule : {EnsembleSchedule::Static, EnsembleSchedule::Dynamic}) {
    const auto items = ensemble_for(
        MPI_COMM_WORLD, 40,
        [](long i, int) -> std::string {
          if (i % 7 == 3) throw std::runtime_error("job " + std::to_string(i) + " refused");
          return "ok " + std::to_string(i);
        },
        options(schedule, 2, 1));
    if (rank_of(MPI_COMM_WORLD) != 0) continue;
    for (long i = 0; i < 40; ++i) {
      const EnsembleItem item = at(items, i);
      EXPECT_EQ(item.error, i % 7 == 3 ? "job " + std::to_string(i) + " refused" : "") << i;
      EXPECT_EQ(item.data, i % 7 == 3 ? "" : "ok " + std::to_string(i)) << i;
    }
  }
}

TEST(Ensemble, ResultsOfAnySizeComeBackWhole) {
  // Empty results, and some of a megabyte (many MPI messages' worth on the shared memory).
  const auto items = ensemble_for(MPI_COMM_WORLD, 12, [](long i, int) {
    return std::string(i % 3 == 0 ? 0 : static_cast<std::size_t>(i) << 17, static_cast<char>('a' + i));
  });
  if (rank_of(MPI_COMM_WORLD) == 0) {
    for (long i = 0; i < 12; ++i)
      EXPECT_EQ(at(items, i).data,
                std::string(i % 3 == 0 ? 0 : static_cast<std::size_t>(i) << 17, static_cast<char>('a' + i)));
  }
}

TEST(Ensemble, TheCallersCommunicatorSeesNoneOfItsMessages) {
  // A receive for anything on the caller's communicator, posted before: still open after.
  MPI_Comm user;
  MPI_Comm_dup(MPI_COMM_WORLD, &user);
  int got = -1;
  MPI_Request request;
  MPI_Irecv(&got, 1, MPI_INT, MPI_ANY_SOURCE, MPI_ANY_TAG, user, &request);
  for (auto schedule : {EnsembleSchedule::Static, EnsembleSchedule::Dynamic})
    ensemble_for(user, 100, square, options(schedule, 1, 3));
  int done = 1;
  MPI_Test(&request, &done, MPI_STATUS_IGNORE);
  EXPECT_EQ(done, 0) << "a message of the ensemble reached the caller's communicator";
  const int mine = 1000 + rank_of(user);  // now complete it ourselves
  MPI_Send(&mine, 1, MPI_INT, rank_of(user), 7, user);
  MPI_Wait(&request, MPI_STATUS_IGNORE);
  EXPECT_EQ(got, mine);
  MPI_Comm_free(&user);
}

TEST(Ensemble, ASplitCommunicatorAndAnotherRoot) {
  // Even and odd ranks apart, each half with its last rank as the root.
  MPI_Comm half;
  MPI_Comm_split(MPI_COMM_WORLD, rank_of(MPI_COMM_WORLD) % 2, 0, &half);
  EnsembleOptions o = options(EnsembleSchedule::Dynamic, 1, 1);
  o.root = size_of(half) - 1;
  const int colour = rank_of(MPI_COMM_WORLD) % 2;
  const auto items = ensemble_for(half, 30, [colour](long i, int) { return std::to_string(100 * colour + i); }, o);
  if (rank_of(half) == o.root) {
    EXPECT_EQ(items.size(), 30u);
    for (long i = 0; i < 30; ++i) EXPECT_EQ(at(items, i).data, std::to_string(100 * colour + i));
  } else {
    EXPECT_TRUE(items.empty());
  }
  MPI_Comm_free(&half);
}

TEST(Ensemble, NothingToDoAndBadArguments) {
  const auto none = ensemble_for(MPI_COMM_WORLD, 0, square);
  EXPECT_TRUE(none.empty());
  auto refused = [](long count, EnsembleOptions o, const std::string& fragment) {
    try {
      ensemble_for(MPI_COMM_WORLD, count, square, o);
      ADD_FAILURE() << "expected: " << fragment;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(fragment));
    }
  };
  refused(-1, {}, "count -1 must not be negative");
  EnsembleOptions o;
  o.root = size_of(MPI_COMM_WORLD);
  refused(5, o, "is not a rank of the communicator");
  o = {};
  o.chunk = -2;
  refused(5, o, "chunk -2");
  o = {};
  o.threads = -1;
  refused(5, o, "threads -1");
  // Still in step: a collective after the refusals completes.
  const auto items = ensemble_for(MPI_COMM_WORLD, 3, square);
  if (rank_of(MPI_COMM_WORLD) == 0) {
    EXPECT_EQ(items.size(), 3u);
  }
}

}  // namespace
}  // namespace nonholo

int main(int argc, char** argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
  ::testing::InitGoogleTest(&argc, argv);
  const int failed = RUN_ALL_TESTS();
  MPI_Finalize();
  return failed;
}
