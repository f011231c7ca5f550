#pragma once
/// @file
/// One call at a time on a workspace. Every entry point that writes a workspace (step, the
/// restarts, the starts, diagnose, dla_step, implicit_step, ...) takes its flag for the whole
/// call; a second caller finds it taken and is refused without touching the workspace: a second
/// thread, or a model callback that re-enters the call running it. Steps then return
/// Status::WorkspaceBusy, set-up calls throw std::invalid_argument("workspace-busy: ...").
/// The refused call writes no message (the workspace's message belongs to the running call).
#include <nonholo/status.hpp>

#include <atomic>

namespace nonholo {

/// The flag a workspace's entry points take (see busy_flag.hpp); only a BusyEntry takes it.
class BusyFlag {
 public:
  BusyFlag() = default;
  BusyFlag(const BusyFlag&) = delete;
  BusyFlag& operator=(const BusyFlag&) = delete;

 private:
  friend class BusyEntry;
  std::atomic<bool> taken_{false};
};

/// Takes the flag for its scope if it is free (held() says whether it did) and gives it back on
/// every exit path. One uncontended atomic exchange and one store.
class BusyEntry {
 public:
  /// Takes `flag` unless another entry holds it.
  explicit BusyEntry(BusyFlag& flag) noexcept
      : flag_(flag.taken_.exchange(true, std::memory_order_acquire) ? nullptr : &flag) {}
  ~BusyEntry() {
    if (flag_) flag_->taken_.store(false, std::memory_order_release);
  }
  BusyEntry(const BusyEntry&) = delete;
  BusyEntry& operator=(const BusyEntry&) = delete;
  bool held() const { return flag_ != nullptr; }  ///< whether this entry took the flag

 private:
  BusyFlag* flag_;
};

/// body() with the flag held, or Status::WorkspaceBusy without running it.
template <class Body>
Status with_flag(BusyFlag& flag, Body&& body) {
  const BusyEntry entry(flag);
  return entry.held() ? body() : Status::WorkspaceBusy;
}

/// For the set-up calls: throws std::invalid_argument "workspace-busy: <call>: ..." unless held.
void require_held(const BusyEntry& entry, const char* call);

}  // namespace nonholo
