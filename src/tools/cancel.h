// Stopping an experiment under way from outside it: Python's Ctrl-C through the engine (issue 33:
// a 200 s run went on 13.5 s after SIGINT; a 1e6 s one would have run for hours). Every
// experiment's step loop asks ThrowIfCancelled before each mj_step, an atomic load; whoever runs
// it (src/python/engine.cc) calls RequestCancel from another thread. Process-wide: a request
// stops every experiment running in the process, as Ctrl-C stops the program that asked.
#ifndef MJSTEPPER_TOOLS_CANCEL_H_
#define MJSTEPPER_TOOLS_CANCEL_H_

#include <stdexcept>

namespace mjstepper::tools {

/// What an experiment throws when asked to stop.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("interrupted") {}
};

/// Asks every experiment under way to stop at its next step.
void RequestCancel();

/// While one lives, an experiment runs (the first one in a process clears an old request, so
/// that a request outlives no call).
class CancelScope {
 public:
  CancelScope();
  ~CancelScope();
  CancelScope(const CancelScope&) = delete;
  CancelScope& operator=(const CancelScope&) = delete;
};

/// Throws Cancelled once RequestCancel has been called.
void ThrowIfCancelled();

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_CANCEL_H_
