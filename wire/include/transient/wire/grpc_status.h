// The one mapping from absl::Status to grpc::Status (DESIGN.md, "Errors"): same code, same
// message.
#pragma once

#include <grpcpp/support/status.h>

#include "absl/status/status.h"

namespace transient::wire {

grpc::Status ToGrpcStatus(const absl::Status& status);
// The inverse, for clients and tests.
absl::Status FromGrpcStatus(const grpc::Status& status);

}  // namespace transient::wire
