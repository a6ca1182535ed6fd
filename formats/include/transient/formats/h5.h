// Ownership of HDF5 identifiers (RAII) and the few typed attribute helpers the tool's files
// need. Everything here speaks HDF5's C API and reports failures as absl::Status.
#pragma once

#include <hdf5.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace transient::h5 {

// Owns one HDF5 identifier and closes it with the H5*close function of its kind.
class Id {
 public:
  using Closer = herr_t (*)(hid_t);

  Id() = default;
  Id(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  Id(Id&& other) noexcept
      : id_(std::exchange(other.id_, H5I_INVALID_HID)), closer_(other.closer_) {}
  Id& operator=(Id&& other) noexcept;
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
  ~Id() { Reset(); }

  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

  // Closes now and reports failure: closing a file flushes it, which can fail (disk full),
  // and a destructor cannot say so.
  absl::Status Close();

 private:
  void Reset();

  hid_t id_ = H5I_INVALID_HID;
  Closer closer_ = nullptr;
};

inline Id File(hid_t id) { return Id(id, H5Fclose); }
inline Id Group(hid_t id) { return Id(id, H5Gclose); }
inline Id Dataset(hid_t id) { return Id(id, H5Dclose); }
inline Id Dataspace(hid_t id) { return Id(id, H5Sclose); }
inline Id Datatype(hid_t id) { return Id(id, H5Tclose); }
inline Id Attribute(hid_t id) { return Id(id, H5Aclose); }
inline Id PropertyList(hid_t id) { return Id(id, H5Pclose); }
inline Id Object(hid_t id) { return Id(id, H5Oclose); }

// Turns off HDF5's printing of its error stack to stderr (once per process): every failure
// is reported through an absl::Status instead.
void SilenceErrorStack();

// Dimensions of a dataset or attribute dataspace; empty for a scalar or null dataspace.
std::vector<hsize_t> Dimensions(hid_t dataspace);

// "[2, 4, 12, 16]".
std::string DimensionsToString(const std::vector<hsize_t>& dims);

// A short human name of a datatype for messages: "float32", "int32", "uint8", "string",
// "enum (1 byte)", "compound".
std::string DescribeType(hid_t type);

// Whether `path` (absolute, e.g. "/moments/real") names an existing link; intermediate groups
// may be missing.
bool LinkExists(hid_t file, absl::string_view path);

// Reads a scalar (or one-element) string attribute stored as a variable-length or a
// fixed-length string; a fixed-length value is cut at its first NUL and trailing spaces are
// dropped. `where` prefixes every error message ("in.h5: /").
absl::StatusOr<std::string> ReadStringAttribute(hid_t object, const char* name,
                                                absl::string_view where);

// Reads a scalar (or one-element) numeric attribute of any integer or float type as a double.
absl::StatusOr<double> ReadNumericAttribute(hid_t object, const char* name,
                                            absl::string_view where);

// Existence and readability of `path`, checked before HDF5 sees it so that the common mistakes
// get their own message rather than HDF5's "unable to open file": NotFound, PermissionDenied,
// InvalidArgument ("is a directory, expected <expected>", "not an HDF5 file").
absl::Status CheckReadableFile(const std::string& path,
                               absl::string_view expected = "an HDF5 file");

// Opens `object` ("/" or an absolute path) of `file` and checks that it is of `kind` (H5I_GROUP
// or H5I_DATASET); `description` completes "missing ..." and "expected a ...". Messages start
// with "<file_path>: <object>". InvalidArgument when missing or of another kind, DataLoss when
// HDF5 cannot open it.
absl::StatusOr<Id> OpenObject(hid_t file, absl::string_view file_path, const std::string& object,
                              H5I_type_t kind, absl::string_view description);

// A dataset stored with a filter this HDF5 library lacks (h5py's lzf, say) opens fine and
// fails at the first read: InvalidArgument naming `where`, the filter's number and name.
absl::Status CheckFiltersAvailable(hid_t dataset, absl::string_view where);

// Scalar attributes as written by the tool: variable-length UTF-8 strings, float64, int64.
absl::Status WriteStringAttribute(hid_t object, const char* name, absl::string_view value);
absl::Status WriteDoubleAttribute(hid_t object, const char* name, double value);
absl::Status WriteInt64Attribute(hid_t object, const char* name, int64_t value);

}  // namespace transient::h5
