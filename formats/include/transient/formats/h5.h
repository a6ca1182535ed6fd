// The HDF5 helper layer every file format of the project is written with: ownership of HDF5
// identifiers (RAII), opening a file for reading, opening and checking groups, datasets and
// attributes against a layout, and creating, reading and writing datasets whole or block by
// block. Everything speaks HDF5's C API and reports failures as absl::Status; a message about
// an object starts with "<file>: <object>" (Where) and names the rule that was broken.
// Not thread-safe, as Debian's HDF5 is not: multi-threaded users hold Hdf5Mutex()
// (hdf5_lock.h) around every call.
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

// The largest image any file of the project holds (2^28 = 16384 x 16384 pixels): one image
// plane is one HDF5 chunk, HDF5 caps chunks below 4 GiB, and 2^28 float32 pixels (1 GiB) leave
// room.
inline constexpr int64_t kMaxImagePixels = int64_t{1} << 28;

// ---------------------------------------------------------------------------------------------
// Identifiers

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

// A file whose writes failed (a full disk, RLIMIT_FSIZE) is still closed by HDF5, which then
// writes its superblock with the end of file it had allocated, past what reached the disk: HDF5
// refuses such a file as truncated. This extends the file to that recorded end (a sparse hole,
// which takes no space on a full disk), so that it opens again and what was flushed before the
// failure reads as before; what was not reads as zeros (a frame's chunk then fails to decode).
// OK when nothing needed doing; FailedPrecondition for a superblock this does not know (not
// version 2 or 3 with 8-byte addresses); the file system's error otherwise.
absl::Status ExtendToRecordedEnd(const std::string& path);

// ---------------------------------------------------------------------------------------------
// Names and descriptions for messages

// "<file>: <object>", the prefix of every message about `object` ("in.h5: /moments/real").
std::string Where(absl::string_view file, absl::string_view object);

// Dimensions of a dataset or attribute dataspace; empty for a scalar or null dataspace.
std::vector<hsize_t> Dimensions(hid_t dataspace);

// "[2, 4, 12, 16]".
std::string DimensionsToString(const std::vector<hsize_t>& dims);

// A short human name of a datatype for messages: "float32", "int32", "uint8", "string",
// "enum (1 byte)", "compound".
std::string DescribeType(hid_t type);

// ---------------------------------------------------------------------------------------------
// Files

// Existence and readability of `path`, checked before HDF5 sees it so that the common mistakes
// get their own message rather than HDF5's "unable to open file": NotFound, PermissionDenied,
// InvalidArgument ("is a directory, expected <expected>", "not an HDF5 file").
absl::Status CheckReadableFile(const std::string& path,
                               absl::string_view expected = "an HDF5 file");

// Whether a file that still carries SWMR's "open for writing" marks in its superblock (a
// recording killed, or still being written) may be opened, through SWMR read.
enum class SwmrRead { kRefuse, kAllow };

// Opens `path` read-only after CheckReadableFile(path, expected) (its codes and messages).
// DataLoss "<path>: HDF5 cannot open the file (...)" when HDF5 refuses it. With kAllow, a file
// that a plain open refuses is opened again in SWMR-read mode, which ignores the marks by
// design and gives up early on a metadata block whose checksum fails (a file cut short).
absl::StatusOr<Id> OpenFileForReading(const std::string& path, absl::string_view expected,
                                      SwmrRead swmr = SwmrRead::kRefuse);

// ---------------------------------------------------------------------------------------------
// Objects

// Whether `path` (absolute, e.g. "/moments/real") names an existing link; intermediate groups
// may be missing.
bool LinkExists(hid_t file, absl::string_view path);

// Opens `object` ("/" or an absolute path) of `file` and checks that it is of `kind` (H5I_GROUP
// or H5I_DATASET); `description` completes "missing ..." and "expected a ...". Messages start
// with "<file_path>: <object>". InvalidArgument when missing or of another kind, DataLoss when
// HDF5 cannot open it.
absl::StatusOr<Id> OpenObject(hid_t file, absl::string_view file_path, const std::string& object,
                              H5I_type_t kind, absl::string_view description);

// OpenObject for a group: "<file>: <object>: missing group".
absl::StatusOr<Id> OpenGroup(hid_t file, absl::string_view file_path, const std::string& object);

// What a dataset must hold. H5T_INTEGER accepts every integer width unless `size` pins one;
// H5T_FLOAT accepts float32 and float64 unless `size` pins one; H5T_NO_CLASS accepts any type
// (the caller checks it). `bool_enum` also accepts h5py's numpy bool, a one-byte enum, where a
// byte is expected.
struct TypeRule {
  H5T_class_t type_class = H5T_FLOAT;
  size_t size = 0;               // bytes; 0 = any width
  const char* name = "float32";  // what messages call the expected type
  bool bool_enum = false;
};
inline constexpr TypeRule kFloat32{H5T_FLOAT, 4, "float32"};
inline constexpr TypeRule kAnyFloat{H5T_FLOAT, 0, "float32 or float64"};
inline constexpr TypeRule kAnyInteger{H5T_INTEGER, 0, "an integer type"};
inline constexpr TypeRule kByte{H5T_INTEGER, 1, "uint8", /*bool_enum=*/true};

// Opens dataset `object`, checks its type, its rank (`shape_description` names the
// dimensions, e.g. "[frames, height, width]") and that the filters it was written with can be
// decoded here (CheckFiltersAvailable). Returns its dimensions in `dims`. InvalidArgument
// "<file>: <object>: missing dataset (<type>, <shape>)", "expected <type>, found int32",
// "expected 3 dimensions [frames, height, width], found 2"; DataLoss when HDF5 cannot open it.
absl::StatusOr<Id> OpenDataset(hid_t file, absl::string_view file_path, const std::string& object,
                               const TypeRule& type, int rank, absl::string_view shape_description,
                               std::vector<hsize_t>* dims);

// InvalidArgument "<where>: expected shape <description> = [..], found [..]" unless equal.
absl::Status CheckShape(absl::string_view where, const std::vector<hsize_t>& dims,
                        const std::vector<hsize_t>& expected, absl::string_view description);

// InvalidArgument "<where>: expected a non-empty image, found height 0 and width 4", or
// "<where>: expected at most 268435456 pixels per image, found 20000 x 20000"
// (kMaxImagePixels); never overflows.
absl::Status CheckImageSize(absl::string_view where, uint64_t height, uint64_t width);

// A dataset stored with a filter this HDF5 library lacks (h5py's lzf, say) opens fine and
// fails at the first read: InvalidArgument naming `where`, the filter's number and name.
absl::Status CheckFiltersAvailable(hid_t dataset, absl::string_view where);

// ---------------------------------------------------------------------------------------------
// Attributes. Readers take `where` ("<file>: <object>", Where) to prefix their messages:
// InvalidArgument "<where>: missing attribute <name>" or "<where>: attribute <name>: expected
// ..., found ...", DataLoss when HDF5 cannot read one that is there.

// A scalar (or one-element) string stored as a variable-length or a fixed-length string; a
// fixed-length value is cut at its first NUL and trailing spaces are dropped.
absl::StatusOr<std::string> ReadStringAttribute(hid_t object, const char* name,
                                                absl::string_view where);

// A scalar (or one-element) number of any integer or float type, as a double.
absl::StatusOr<double> ReadNumericAttribute(hid_t object, const char* name,
                                            absl::string_view where);

// A finite number, optionally > 0 or >= 0: "expected a finite value > 0, found -1".
enum class Sign { kAny, kPositive, kNonNegative };
absl::StatusOr<double> ReadFiniteAttribute(hid_t object, const char* name, absl::string_view where,
                                           Sign sign);

// An integer (stored as any number type) in [min, max]: "expected an integer in 1..16, found
// 7.5".
absl::StatusOr<int64_t> ReadIntegerAttribute(hid_t object, const char* name,
                                             absl::string_view where, int64_t min, int64_t max);

// A one-dimensional array of exactly `length` numbers, as doubles: "expected 5 float64 values,
// found float64 [4]".
absl::StatusOr<std::vector<double>> ReadDoubleArrayAttribute(hid_t object, const char* name,
                                                             absl::string_view where,
                                                             size_t length);

// Attributes as the project writes them: scalar variable-length UTF-8 strings, float64, int64,
// and float64 arrays. An attribute of that name is replaced. Internal when HDF5 fails.
absl::Status WriteStringAttribute(hid_t object, const char* name, absl::string_view value);
absl::Status WriteDoubleAttribute(hid_t object, const char* name, double value);
absl::Status WriteInt64Attribute(hid_t object, const char* name, int64_t value);
absl::Status WriteDoubleArrayAttribute(hid_t object, const char* name,
                                       const std::vector<double>& values);

// ---------------------------------------------------------------------------------------------
// Datasets

// How CreateDataset lays a dataset out.
struct DatasetLayout {
  std::vector<hsize_t> dims;           // the current extent
  std::vector<hsize_t> max_dims = {};  // empty: fixed at dims; H5S_UNLIMITED makes it extendible
  std::vector<hsize_t> chunk = {};     // empty: contiguous (needs fixed dims)
  hid_t fill_type = H5I_INVALID_HID;   // memory type of *fill; with fill == nullptr: HDF5's zero
  const void* fill = nullptr;          // what unwritten elements read as
  int deflate_level = 0;               // 1..9: shuffle + deflate of each chunk (needs chunk)
};

// Creates dataset `name` in `parent` of `file_type`. Internal "cannot create dataset <name>"
// when HDF5 refuses the layout or the dataset.
absl::StatusOr<Id> CreateDataset(hid_t parent, const char* name, hid_t file_type,
                                 const DatasetLayout& layout);

// Creates a contiguous dataset `name` in `parent` with the given file type and shape and writes
// `data` (of `memory_type`, row-major) into all of it. Internal when HDF5 fails.
absl::Status WriteDataset(hid_t parent, const char* name, hid_t file_type, hid_t memory_type,
                          const std::vector<hsize_t>& dims, const void* data);

// Reads a whole dataset converted to `memory_type` into `data` (sized by the caller). DataLoss
// "<where>: cannot be read (corrupt or truncated file)".
absl::Status ReadDataset(hid_t dataset, hid_t memory_type, void* data, absl::string_view where);

// The block of `dataset` that starts at `start` and spans `count` (one entry per dimension),
// read into or written from `data` (of `memory_type`, row-major, the block's size). The status
// says only that HDF5 failed (DataLoss for reads, Internal for writes): callers name the file,
// the object and the frame.
absl::Status ReadBlock(hid_t dataset, const std::vector<hsize_t>& start,
                       const std::vector<hsize_t>& count, hid_t memory_type, void* data);
absl::Status WriteBlock(hid_t dataset, const std::vector<hsize_t>& start,
                        const std::vector<hsize_t>& count, hid_t memory_type, const void* data);

// Extends an extendible `dataset` to index + 1 along its first dimension and writes `data` as
// entry `index` of it (one element, or one [1, ...] slab of the other dimensions). Internal
// when HDF5 fails.
absl::Status AppendAlongFirst(hid_t dataset, hsize_t index, hid_t memory_type, const void* data);

}  // namespace transient::h5
