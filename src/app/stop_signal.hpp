#pragma once
// Ctrl-C (SIGINT) and SIGTERM during `vslam run`: the first asks the run to
// stop reading frames and write what it has; the second also skips the final
// bundle adjustment; a third ends the process at once (the default action).
//
// The one piece of global state in vslam, because a signal handler can reach
// nothing else: the handler only stores into lock-free atomics, which the run
// loop polls.
#include <signal.h>

#include <atomic>

namespace vslam::app {

struct StopRequest {
  std::atomic<int> signal{0};              // the first signal received (SIGINT, SIGTERM), 0 = none
  std::atomic<bool> skip_final_ba{false};  // a second signal came
};

// While it lives, SIGINT and SIGTERM set its request instead of ending the
// process; the handlers before it come back when it goes. One at a time.
class StopSignals {
 public:
  StopSignals();
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;
  const StopRequest& request() const;

 private:
  struct sigaction previous_interrupt_ = {}, previous_terminate_ = {};
};

}  // namespace vslam::app
