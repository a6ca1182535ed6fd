// Tests of grpc_status.h: every code maps to the gRPC code of the same meaning, messages are
// kept, and the inverse undoes the mapping.
#include "transient/wire/grpc_status.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <utility>
#include <vector>

namespace transient::wire {
namespace {

// Spelled out pairwise, so the test does not rest on the numbering the implementation may use.
const std::vector<std::pair<absl::StatusCode, grpc::StatusCode>>& AllCodes() {
  static const auto* codes = new std::vector<std::pair<absl::StatusCode, grpc::StatusCode>>{
      {absl::StatusCode::kCancelled, grpc::StatusCode::CANCELLED},
      {absl::StatusCode::kUnknown, grpc::StatusCode::UNKNOWN},
      {absl::StatusCode::kInvalidArgument, grpc::StatusCode::INVALID_ARGUMENT},
      {absl::StatusCode::kDeadlineExceeded, grpc::StatusCode::DEADLINE_EXCEEDED},
      {absl::StatusCode::kNotFound, grpc::StatusCode::NOT_FOUND},
      {absl::StatusCode::kAlreadyExists, grpc::StatusCode::ALREADY_EXISTS},
      {absl::StatusCode::kPermissionDenied, grpc::StatusCode::PERMISSION_DENIED},
      {absl::StatusCode::kResourceExhausted, grpc::StatusCode::RESOURCE_EXHAUSTED},
      {absl::StatusCode::kFailedPrecondition, grpc::StatusCode::FAILED_PRECONDITION},
      {absl::StatusCode::kAborted, grpc::StatusCode::ABORTED},
      {absl::StatusCode::kOutOfRange, grpc::StatusCode::OUT_OF_RANGE},
      {absl::StatusCode::kUnimplemented, grpc::StatusCode::UNIMPLEMENTED},
      {absl::StatusCode::kInternal, grpc::StatusCode::INTERNAL},
      {absl::StatusCode::kUnavailable, grpc::StatusCode::UNAVAILABLE},
      {absl::StatusCode::kDataLoss, grpc::StatusCode::DATA_LOSS},
      {absl::StatusCode::kUnauthenticated, grpc::StatusCode::UNAUTHENTICATED},
  };
  return *codes;
}

TEST(ToGrpcStatus, OkIsOk) {
  const grpc::Status status = ToGrpcStatus(absl::OkStatus());
  EXPECT_TRUE(status.ok());
  EXPECT_EQ(status.error_code(), grpc::StatusCode::OK);
  EXPECT_EQ(status.error_message(), "");
}

TEST(ToGrpcStatus, EveryErrorCodeKeepsItsMeaningAndMessage) {
  for (const auto& [absl_code, grpc_code] : AllCodes()) {
    SCOPED_TRACE(absl::StatusCodeToString(absl_code));
    const std::string message = "roi: x=200 + width=10 reaches outside the 163x120 sensor";
    const grpc::Status status = ToGrpcStatus(absl::Status(absl_code, message));
    EXPECT_FALSE(status.ok());
    EXPECT_EQ(status.error_code(), grpc_code);
    EXPECT_EQ(status.error_message(), message);
  }
}

TEST(FromGrpcStatus, UndoesToGrpcStatus) {
  EXPECT_TRUE(FromGrpcStatus(grpc::Status::OK).ok());
  for (const auto& [absl_code, grpc_code] : AllCodes()) {
    SCOPED_TRACE(absl::StatusCodeToString(absl_code));
    const absl::Status original(absl_code, "image \"depth\": step=17");
    EXPECT_EQ(FromGrpcStatus(ToGrpcStatus(original)), original);
    EXPECT_EQ(FromGrpcStatus(grpc::Status(grpc_code, "m")), absl::Status(absl_code, "m"));
  }
}

TEST(FromGrpcStatus, UnknownGrpcCodeIsUnknown) {
  // 17, the first unassigned code: still inside the enum's range of values (UBSan checks that),
  // as a code from a newer gRPC would be.
  const absl::Status status =
      FromGrpcStatus(grpc::Status(static_cast<grpc::StatusCode>(17), "from the future"));
  EXPECT_EQ(status.code(), absl::StatusCode::kUnknown);
  EXPECT_EQ(status.message(), "from the future");
}

}  // namespace
}  // namespace transient::wire
