#include "core/stop_signal.hpp"

namespace msflex {

namespace {
volatile std::sig_atomic_t g_stop_signal = 0;
}

int StopSignalReceived() { return (int)g_stop_signal; }

extern "C" void RecordStopSignal(int signal) { g_stop_signal = signal; }

void ClearStopSignal() { g_stop_signal = 0; }

} // namespace msflex
