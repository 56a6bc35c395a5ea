// The stop signal of a run (SIGTERM, SIGUSR1, SIGINT, SIGHUP): recorded by the handler that
// app/run_analysis.cpp installs, read wherever a long computation can end early with what it has
// (the step loop after every step, the eigensolver's stopping test).
#pragma once

#include <csignal>

namespace msflex {

// The signal that asked the run to stop, 0 if none (this process's; agree over the ranks before acting).
int StopSignalReceived();
// The handler's work (async-signal-safe), and the reset when handlers are installed.
extern "C" void RecordStopSignal(int signal);
void            ClearStopSignal();

} // namespace msflex
