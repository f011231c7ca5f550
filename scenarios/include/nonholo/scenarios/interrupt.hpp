#pragma once
/// @file
/// Ctrl-C (or SIGTERM, SIGHUP) during `nonholo run` / `batch`: the handler only sets a flag; the step loops check it
/// between steps, finish the CSV row they are on, and end with status=interrupted, so the
/// output stays valid and the summary is printed. Installed by the command-line tool only
/// (InterruptScope); a library caller's own SIGINT handling is left alone.
namespace nonholo::scenarios {

/// Whether SIGINT, SIGTERM or SIGHUP arrived in an InterruptScope, or request_interrupt() was called.
bool interrupt_requested();
/// "SIGINT" (Ctrl-C), "SIGTERM" (mpirun's, kill's) or "SIGHUP" (the terminal closed): which one asked.
const char* interrupt_name();
/// Asks the step loops to stop, as Ctrl-C does (for tests and for a caller with its own handler).
void request_interrupt();

/// SIGINT, SIGTERM and SIGHUP set the flag while in scope (mpirun turns Ctrl-C into SIGTERM for
/// its ranks, and a SIGKILL a second later unless it is told to wait: docs/guide/mpi.md; SIGHUP
/// stays ignored where it was, under nohup); the previous handlers and a clear flag come back after.
class InterruptScope {
 public:
  InterruptScope();   ///< installs the handlers and clears the flag
  ~InterruptScope();  ///< puts the previous handlers back and clears the flag
  InterruptScope(const InterruptScope&) = delete;             ///< one scope, one installation
  InterruptScope& operator=(const InterruptScope&) = delete;  ///< one scope, one installation

 private:
  void (*previous_)(int);
  void (*previous_term_)(int);
  void (*previous_hup_)(int);
};

}  // namespace nonholo::scenarios
