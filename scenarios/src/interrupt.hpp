#pragma once
// Ctrl-C during `nonholo run` / `batch`: the handler only sets a flag; the step loops check it
// between steps, finish the CSV row they are on, and end with status=interrupted, so the
// output stays valid and the summary is printed. Installed by the command-line tool only
// (InterruptScope); a library caller's own SIGINT handling is left alone.
namespace nonholo::scenarios {

bool interrupt_requested();
const char* interrupt_name();  // "SIGINT" (Ctrl-C) or "SIGTERM" (mpirun's, kill's)
// For tests and for a caller with its own handler: ask the loops to stop.
void request_interrupt();

// SIGINT and SIGTERM set the flag while in scope (mpirun turns Ctrl-C into SIGTERM for its
// ranks, and a SIGKILL a second later unless it is told to wait: docs/guide/mpi.md); the
// previous handlers and a clear flag come back after.
class InterruptScope {
 public:
  InterruptScope();
  ~InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  void (*previous_)(int);
  void (*previous_term_)(int);
};

}  // namespace nonholo::scenarios
