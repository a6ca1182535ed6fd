// Writing a file under a temporary name beside its final path and renaming it into place at
// the end, so that a failed or interrupted run leaves no partial output behind.
#pragma once

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace transient {

class TemporaryOutput {
 public:
  // Checks that `final_path` can be written (its directory exists, it is not itself a
  // directory) and names the temporary file "<final_path>.tmp-<pid>"; creates nothing.
  [[nodiscard]] static absl::StatusOr<TemporaryOutput> Prepare(const std::string& final_path);

  TemporaryOutput(TemporaryOutput&& other) noexcept;
  TemporaryOutput& operator=(TemporaryOutput&&) = delete;
  TemporaryOutput(const TemporaryOutput&) = delete;
  TemporaryOutput& operator=(const TemporaryOutput&) = delete;
  // Removes the temporary file unless Commit() succeeded.
  ~TemporaryOutput();

  const std::string& temporary_path() const { return temporary_path_; }
  const std::string& final_path() const { return final_path_; }

  // Renames the (closed) temporary file to the final path, replacing what was there.
  absl::Status Commit();

 private:
  TemporaryOutput(std::string final_path, std::string temporary_path)
      : final_path_(std::move(final_path)), temporary_path_(std::move(temporary_path)) {}

  std::string final_path_;
  std::string temporary_path_;
  bool armed_ = true;  // the destructor removes temporary_path_
};

}  // namespace transient
