#include "stop_signal.hpp"

namespace vslam::app {
namespace {

StopRequest g_stop_request;  // written only by handleStopSignal (see stop_signal.hpp)
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free,
              "signal handlers may only touch lock-free atomics");

extern "C" void handleStopSignal(int signal_number) {
  int none = 0;
  if (g_stop_request.signal.compare_exchange_strong(none, signal_number)) return;
  if (!g_stop_request.skip_final_ba.exchange(true)) return;
  // A third: the user means it.
  struct sigaction default_action = {};
  default_action.sa_handler = SIG_DFL;
  sigaction(signal_number, &default_action, nullptr);
  raise(signal_number);
}

}  // namespace

StopSignals::StopSignals() {
  g_stop_request.signal = 0;
  g_stop_request.skip_final_ba = false;
  struct sigaction action = {};
  action.sa_handler = handleStopSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGINT, &action, &previous_interrupt_);
  sigaction(SIGTERM, &action, &previous_terminate_);
}

StopSignals::~StopSignals() {
  sigaction(SIGINT, &previous_interrupt_, nullptr);
  sigaction(SIGTERM, &previous_terminate_, nullptr);
}

const StopRequest& StopSignals::request() const { return g_stop_request; }

}  // namespace vslam::app
