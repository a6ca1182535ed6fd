// Connecting to the test daemon in the client library's tests.
#pragma once

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "absl/status/statusor.h"
#include "tests/support/status_matchers.h"
#include "transient/client/client.h"

namespace transient::testing {

// A client of the daemon at `address` with the default options; a failure to connect fails
// the test (and the returned client's calls fail too).
inline client::Client MustConnect(const std::string& address) {
  absl::StatusOr<client::Client> client = client::Client::Connect({.address = address});
  EXPECT_THAT(client.status(), IsOk());
  return *std::move(client);
}

}  // namespace transient::testing
