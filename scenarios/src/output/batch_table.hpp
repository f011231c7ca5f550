#pragma once
// The batch's table as CSV (`nonholo batch --out FILE.csv`): one row per trajectory with its
// varied values, final time, body 0's first coordinates and errors; and the journal of rows as
// they finish (OUT.partial.csv), so that a killed batch keeps every trajectory that finished.
#include <nonholo/scenarios/batch_types.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <memory>
#include <mutex>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

namespace nonholo::scenarios {

// The batch's table as CSV: one row per trajectory, in order. Throws std::runtime_error on a
// write error.
void write_batch_csv(std::ofstream& out, const std::string& path, const BatchResult& result, bool error_estimate);

// Rows as trajectories finish, beside the batch's output (OUT.partial.csv; under MPI each rank
// its own, OUT.partial.rankR.csv): a batch killed before it ends keeps the trajectories that
// finished (nonholo.load reads the file; the rows carry their trajectory index). Each thread
// gathers its rows in a block of its own and appends the block in one write(2), to a file opened
// for appending, once its oldest row is kJournalDelay old or the block is full; a flusher thread
// writes the blocks of threads busy with long trajectories. No lock shared by the threads and a
// system call per block, not per row (a single sleigh's row cost as much as its 10 steps,
// 5.5 us); whole rows only (a full disk aside, whose short write may end one mid-row). A kill
// loses the rows of about the last 2 kJournalDelay at most. flush() writes the rest once the
// threads are done; the file is removed once the output is written.
class Journal {
 public:
  static constexpr double kJournalDelay = 0.1;  // seconds a finished row may wait in memory

  // No journal without an output; throws std::invalid_argument when the file cannot be opened.
  Journal(const std::string& out, const BatchProcesses* processes, bool error_estimate);
  ~Journal();  // flush()es: a batch that failed keeps the rows it finished
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;
  // Before the rows: the threads that will add them (add's `thread`, 0 ... threads - 1); starts
  // the flusher. Without it, each row is written at once.
  void begin(int threads);
  // A finished row, from thread `thread`, concurrently with the others. The header comes with
  // the first: its names (body 0's coordinates) are known once a trajectory was set up; only
  // until it is written do rows take a lock.
  void add(long i, int thread, const BatchResult::Trajectory& row, const std::vector<std::string>& varied,
           const std::vector<std::string>& names);
  bool active() const { return fd_ >= 0; }  // false: no output, no journal
  // Stops the flusher and writes every thread's rows; call when no thread adds any more.
  void flush();
  void remove();

 private:
  struct alignas(64) Block {  // one thread's rows not yet written, on cache lines of its own
    std::mutex mutex;  // its thread's, and the flusher's now and then
    std::string text;
    std::chrono::steady_clock::time_point oldest;
  };
  using Clock = std::chrono::steady_clock;
  void append(const std::string& text);  // one write, retried for what a short write left
  void write_block(Block& b);            // under b.mutex
  void flusher();                        // the flusher thread's loop
  std::string path_;
  int fd_ = -1;
  std::unique_ptr<Block[]> blocks_;
  int block_count_ = 0;
  std::thread flusher_;
  std::mutex stop_mutex_;
  std::condition_variable stop_;
  bool stopping_ = false;
  std::mutex header_mutex_;
  std::atomic<bool> header_{false};  // set (release) once the header is in the file
  bool has_work_ = false, error_estimate_;
};

}  // namespace nonholo::scenarios
