#include "cancel.h"

#include <atomic>

namespace mjstepper::tools {
namespace {

std::atomic<bool> cancel_requested{false};
std::atomic<int> scopes{0};  // experiments under way

}  // namespace

void RequestCancel() { cancel_requested.store(true, std::memory_order_relaxed); }

CancelScope::CancelScope() {
  if (scopes.fetch_add(1) == 0) cancel_requested.store(false, std::memory_order_relaxed);
}

CancelScope::~CancelScope() { scopes.fetch_sub(1); }

void ThrowIfCancelled() {
  if (cancel_requested.load(std::memory_order_relaxed)) throw Cancelled();
}

}  // namespace mjstepper::tools
