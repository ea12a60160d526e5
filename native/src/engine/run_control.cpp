#include "engine/run_control.hpp"

namespace granular {

namespace {
volatile std::sig_atomic_t g_stop = 0;

extern "C" void on_stop(int sig) {
  if (g_stop) {  // asked twice: stop now
    std::signal(sig, SIG_DFL);
    std::raise(sig);
    return;
  }
  g_stop = sig;
}
}  // namespace

void install_stop_handlers() {
  std::signal(SIGINT, on_stop);
  std::signal(SIGTERM, on_stop);
}

int stop_signal() { return g_stop; }

}  // namespace granular
