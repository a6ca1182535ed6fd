// Which of the project's four HDF5 file formats a file is, told by its root `format` attribute
// alone (format_tag.h), before any reader checks its layout: what `transient info` and
// `transient view` decide their work by.
#pragma once

#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/formats/format_tag.h"

namespace transient {

enum class FileFormat {
  kCapture,         // capture_file.h
  kCalibration,     // calibration_file.h
  kMoments,         // moment_file.h
  kReconstruction,  // reconstruction_file.h
};
inline constexpr FileFormat kFileFormats[] = {FileFormat::kCapture, FileFormat::kCalibration,
                                              FileFormat::kMoments, FileFormat::kReconstruction};

// The name ("transient-capture") and the major version this build reads and writes, as the
// format's own header defines them.
absl::string_view FormatName(FileFormat format);
int FormatMajor(FileFormat format);

// What a file says it is.
struct FileIdentity {
  std::string text;                 // the attribute as stored: "transient-moments 1.2"
  std::optional<FormatTag> tag;     // nullopt when text is not "NAME MAJOR[.MINOR]"
  std::optional<FileFormat> named;  // the format its first word names, whatever the version

  // Whether the file is `format` in a version this build reads (CheckFormatTag passes).
  bool Is(FileFormat format) const;
};

// Opens `path` read-only, a capture still being written (or killed while it was) included
// (h5::SwmrRead::kAllow), and reads its root attribute `format`; checks nothing else.
// `expected` completes "is a directory, expected ..." ("an HDF5 file" by default). NotFound,
// PermissionDenied, InvalidArgument (a directory, not HDF5, "<path>: /: missing attribute
// format" with a hint that the file is none of the project's, a format that is not a
// string), DataLoss (HDF5 cannot open it).
[[nodiscard]] absl::StatusOr<FileIdentity> IdentifyFile(
    const std::string& path, absl::string_view expected = "an HDF5 file");

}  // namespace transient
