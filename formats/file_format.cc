// Telling the project's file formats apart by their root `format` attribute.
#include "transient/formats/file_format.h"

#include "absl/strings/str_cat.h"
#include "transient/formats/calibration_file.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/h5.h"
#include "transient/formats/moment_file.h"
#include "transient/formats/reconstruction_file.h"

namespace transient {

absl::string_view FormatName(FileFormat format) {
  switch (format) {
    case FileFormat::kCapture:
      return kCaptureFormatName;
    case FileFormat::kCalibration:
      return kCalibrationFormatName;
    case FileFormat::kMoments:
      return kMomentFormatName;
    case FileFormat::kReconstruction:
      return kReconstructionFormatName;
  }
  return "";
}

int FormatMajor(FileFormat format) {
  switch (format) {
    case FileFormat::kCapture:
      return kCaptureFormatMajor;
    case FileFormat::kCalibration:
      return kCalibrationFormatMajor;
    case FileFormat::kMoments:
      return kMomentFormatMajor;
    case FileFormat::kReconstruction:
      return kReconstructionFormatMajor;
  }
  return 0;
}

bool FileIdentity::Is(FileFormat format) const {
  return named == format && CheckFormatTag(text, FormatName(format), FormatMajor(format)).ok();
}

absl::StatusOr<FileIdentity> IdentifyFile(const std::string& path, absl::string_view expected) {
  absl::StatusOr<h5::Id> file = h5::OpenFileForReading(path, expected, h5::SwmrRead::kAllow);
  if (!file.ok()) return file.status();
  const std::string root = h5::Where(path, "/");
  if (H5Aexists(file->get(), "format") <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        root, ": missing attribute format (an HDF5 file, but none of this project's formats)"));
  }
  absl::StatusOr<std::string> text = h5::ReadStringAttribute(file->get(), "format", root);
  if (!text.ok()) return text.status();
  FileIdentity identity;
  identity.text = *text;
  identity.tag = ParseFormatTag(*text);
  // By the first word, so that a file of a known name with a malformed or unknown version is
  // still recognised, and its reader says what is wrong with the version.
  const absl::string_view name =
      absl::string_view(identity.text).substr(0, identity.text.find(' '));
  for (FileFormat format : kFileFormats) {
    if (name == FormatName(format)) identity.named = format;
  }
  return identity;
}

}  // namespace transient
