// Ctrl-C, SIGTERM and SIGHUP as a flag the step loops poll (<nonholo/scenarios/interrupt.hpp>).
#include <nonholo/scenarios/interrupt.hpp>

#include <atomic>
#include <csignal>

namespace nonholo::scenarios {
namespace {

std::atomic<int> g_interrupted{0};  // lock-free, so safe to set from a signal handler
static_assert(std::atomic<int>::is_always_lock_free);

extern "C" void on_sigint(int signal) { g_interrupted.store(signal, std::memory_order_relaxed); }

}  // namespace

bool interrupt_requested() { return g_interrupted.load(std::memory_order_relaxed) != 0; }
const char* interrupt_name() {
  const int signal = g_interrupted.load(std::memory_order_relaxed);
  return signal == SIGTERM ? "SIGTERM" : signal == SIGHUP ? "SIGHUP" : "SIGINT";
}
void request_interrupt() { g_interrupted.store(1, std::memory_order_relaxed); }

InterruptScope::InterruptScope()
    : previous_(std::signal(SIGINT, on_sigint)),
      previous_term_(std::signal(SIGTERM, on_sigint)),
      previous_hup_(std::signal(SIGHUP, on_sigint)) {
  // A hang-up (the terminal closed) ends the run as SIGTERM does, its last row whole; under
  // nohup (SIGHUP ignored) it stays ignored.
  if (previous_hup_ == SIG_IGN) std::signal(SIGHUP, SIG_IGN);
  g_interrupted.store(0);
}

InterruptScope::~InterruptScope() {
  std::signal(SIGINT, previous_ == SIG_ERR ? SIG_DFL : previous_);
  std::signal(SIGTERM, previous_term_ == SIG_ERR ? SIG_DFL : previous_term_);
  std::signal(SIGHUP, previous_hup_ == SIG_ERR ? SIG_DFL : previous_hup_);
  g_interrupted.store(0);
}

}  // namespace nonholo::scenarios
