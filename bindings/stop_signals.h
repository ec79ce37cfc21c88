#pragma once
// Stop signals held from the first instant: `dca run`, `dca scenario` and `dca supervise` call
// hold_stop_signals() first thing in main, so a Ctrl-C, SIGTERM or SIGHUP that arrives before their loop
// listens for it is noted (core.pending_signal()) instead of killing the process half-way through starting
// daemons. Their start-up checks core.pending_signal() between steps; once the loop runs, core.on_signal
// takes over (and they check the pending one once more).
namespace dca::bindings {
void hold_stop_signals();
}
