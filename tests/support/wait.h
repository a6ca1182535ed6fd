// Waiting for something that happens on another thread or in another process, without a fixed
// sleep: the tests poll a condition with a deadline instead.
#pragma once

#include <chrono>
#include <functional>

#include "absl/time/time.h"

namespace transient::testing {

// Polls `condition` every few milliseconds until it holds (true) or `timeout` passes (false).
// Generous timeouts are right here: a passing test returns as soon as the condition holds.
bool WaitUntil(const std::function<bool()>& condition,
               absl::Duration timeout = absl::Seconds(10));

// Seconds of the steady clock since `start`, for bounds on how long something took.
double SecondsSince(std::chrono::steady_clock::time_point start);

}  // namespace transient::testing
