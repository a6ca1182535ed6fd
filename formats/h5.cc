// The HDF5 helper layer over HDF5's C API (h5.h).
#include "transient/formats/h5.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"

namespace transient::h5 {
namespace {

// SWMR readers retry a metadata block whose checksum fails, with exponential back-off, 100 times
// by default: right for a block a live writer is rewriting, endless for a file cut short. A few
// attempts tell the two apart.
constexpr unsigned kSwmrReadAttempts = 4;

// HDF5 closes the files still open at exit from an atexit handler. A file whose close failed
// (its writes failed: a full disk) stays half closed in HDF5 1.10, and that handler then
// crashes in H5F__close_cb. Every file here is closed by its owner (Id), so the handler has
// nothing to do: it is not registered. H5dont_atexit works only before HDF5 initialises, hence
// at static initialisation.
[[maybe_unused]] const bool kNoHdf5AtExit = [] {
  H5dont_atexit();
  return true;
}();

}  // namespace

// ---------------------------------------------------------------------------------------------
// Identifiers

Id& Id::operator=(Id&& other) noexcept {
  if (this != &other) {
    Reset();
    id_ = std::exchange(other.id_, H5I_INVALID_HID);
    closer_ = other.closer_;
  }
  return *this;
}

void Id::Reset() {
  if (valid() && closer_ != nullptr) closer_(id_);
  id_ = H5I_INVALID_HID;
}

absl::Status Id::Close() {
  if (!valid()) return absl::OkStatus();
  const herr_t result = closer_(std::exchange(id_, H5I_INVALID_HID));
  if (result < 0) return absl::InternalError("closing an HDF5 object failed");
  return absl::OkStatus();
}

void SilenceErrorStack() {
  static std::once_flag once;
  std::call_once(once, [] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); });
}

absl::Status ExtendToRecordedEnd(const std::string& path) {
  // Superblock versions 2 and 3 (HDF5 file format specification 3.0, "Superblock"): signature
  // (8 bytes), version, size of offsets, size of lengths, file consistency flags, then the base
  // address, the superblock extension address and the end of file address, little endian.
  constexpr unsigned char kSignature[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
  constexpr size_t kBaseAddress = 12, kEndOfFileAddress = 28, kRead = 36;
  unsigned char header[kRead];
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) return absl::ErrnoToStatus(errno, absl::StrCat(path, ": cannot be read"));
  const size_t got = std::fread(header, 1, kRead, file);
  std::fclose(file);
  if (got < kRead || std::memcmp(header, kSignature, sizeof(kSignature)) != 0 ||
      (header[8] != 2 && header[8] != 3) || header[9] != 8) {
    return absl::FailedPreconditionError(
        absl::StrCat(path, ": not an HDF5 file with a version 2 or 3 superblock"));
  }
  auto address = [&](size_t at) {
    uint64_t value = 0;
    for (int i = 7; i >= 0; --i) value = (value << 8) | header[at + static_cast<size_t>(i)];
    return value;
  };
  const uint64_t end = address(kBaseAddress) + address(kEndOfFileAddress);
  std::error_code error;
  const uint64_t size = std::filesystem::file_size(path, error);
  if (error) return absl::ErrnoToStatus(error.value(), absl::StrCat(path, ": "));
  if (size >= end) return absl::OkStatus();
  std::filesystem::resize_file(path, end, error);
  if (error) {
    return absl::ErrnoToStatus(error.value(),
                               absl::StrCat(path, ": cannot be extended to ", end, " bytes"));
  }
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// Names and descriptions for messages

std::string Where(absl::string_view file, absl::string_view object) {
  return absl::StrCat(file, ": ", object);
}

std::vector<hsize_t> Dimensions(hid_t dataspace) {
  const int rank = H5Sget_simple_extent_ndims(dataspace);
  if (rank <= 0) return {};
  std::vector<hsize_t> dims(rank);
  H5Sget_simple_extent_dims(dataspace, dims.data(), nullptr);
  return dims;
}

std::string DimensionsToString(const std::vector<hsize_t>& dims) {
  return absl::StrCat("[", absl::StrJoin(dims, ", "), "]");
}

std::string DescribeType(hid_t type) {
  const size_t bits = 8 * H5Tget_size(type);
  switch (H5Tget_class(type)) {
    case H5T_INTEGER:
      return absl::StrCat(H5Tget_sign(type) == H5T_SGN_NONE ? "uint" : "int", bits);
    case H5T_FLOAT:
      return absl::StrCat("float", bits);
    case H5T_STRING:
      return "string";
    case H5T_ENUM:
      return absl::StrCat("enum (", bits / 8, " byte", bits == 8 ? "" : "s", ")");
    case H5T_COMPOUND:
      return "compound";
    case H5T_ARRAY:
      return "array";
    case H5T_VLEN:
      return "variable-length sequence";
    case H5T_BITFIELD:
      return "bitfield";
    case H5T_OPAQUE:
      return "opaque";
    case H5T_REFERENCE:
      return "reference";
    case H5T_TIME:
      return "time";
    default:
      return "unknown type";
  }
}

// ---------------------------------------------------------------------------------------------
// Files

absl::Status CheckReadableFile(const std::string& path, absl::string_view expected) {
  std::error_code error;
  const std::filesystem::file_status status = std::filesystem::status(path, error);
  if (!std::filesystem::exists(status)) {
    return absl::NotFoundError(absl::StrCat(path, ": no such file"));
  }
  if (std::filesystem::is_directory(status)) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": is a directory, expected ", expected));
  }
  std::FILE* stream = std::fopen(path.c_str(), "rb");
  if (stream == nullptr) {
    const int reason = errno;
    const std::string message =
        absl::StrCat(path, ": cannot be read (", std::strerror(reason), ")");
    return reason == EACCES ? absl::PermissionDeniedError(message)
                            : absl::InvalidArgumentError(message);
  }
  std::fclose(stream);
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": not an HDF5 file"));
  }
  return absl::OkStatus();
}

absl::StatusOr<Id> OpenFileForReading(const std::string& path, absl::string_view expected,
                                      SwmrRead swmr) {
  SilenceErrorStack();
  if (absl::Status readable = CheckReadableFile(path, expected); !readable.ok()) return readable;
  Id file = File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (file.valid()) return file;
  if (swmr == SwmrRead::kRefuse) {
    return absl::DataLossError(
        absl::StrCat(path, ": HDF5 cannot open the file (corrupt, truncated or locked)"));
  }
  // SWMR needs the 1.10 file format (superblock version 3).
  Id access = PropertyList(H5Pcreate(H5P_FILE_ACCESS));
  H5Pset_libver_bounds(access.get(), H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
  H5Pset_metadata_read_attempts(access.get(), kSwmrReadAttempts);
  file = File(H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, access.get()));
  if (file.valid()) return file;
  return absl::DataLossError(absl::StrCat(
      path, ": HDF5 cannot open the file (corrupt, truncated, or being written without SWMR)"));
}

// ---------------------------------------------------------------------------------------------
// Objects

bool LinkExists(hid_t file, absl::string_view path) {
  // H5Lexists fails (rather than answering false) when an intermediate group is missing, so
  // walk the path one component at a time.
  std::string prefix;
  for (absl::string_view part : absl::StrSplit(path, '/', absl::SkipEmpty())) {
    absl::StrAppend(&prefix, "/", part);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
  }
  return true;
}

absl::StatusOr<Id> OpenObject(hid_t file, absl::string_view file_path, const std::string& object,
                              H5I_type_t kind, absl::string_view description) {
  const std::string where = Where(file_path, object);
  if (object != "/" && !LinkExists(file, object)) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": missing ", description));
  }
  Id id = Object(H5Oopen(file, object.c_str(), H5P_DEFAULT));
  if (!id.valid()) return absl::DataLossError(absl::StrCat(where, ": cannot be opened"));
  if (H5Iget_type(id.get()) != kind) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": expected a ", description, ", found another kind of object"));
  }
  return id;
}

absl::StatusOr<Id> OpenGroup(hid_t file, absl::string_view file_path, const std::string& object) {
  return OpenObject(file, file_path, object, H5I_GROUP, "group");
}

absl::StatusOr<Id> OpenDataset(hid_t file, absl::string_view file_path, const std::string& object,
                               const TypeRule& type, int rank, absl::string_view shape_description,
                               std::vector<hsize_t>* dims) {
  absl::StatusOr<Id> dataset =
      OpenObject(file, file_path, object, H5I_DATASET,
                 absl::StrCat("dataset (", type.name, ", ", shape_description, ")"));
  if (!dataset.ok()) return dataset.status();
  const std::string where = Where(file_path, object);
  Id file_type = Datatype(H5Dget_type(dataset->get()));
  const H5T_class_t found_class = H5Tget_class(file_type.get());
  const size_t found_size = H5Tget_size(file_type.get());
  const bool class_ok = type.type_class == H5T_NO_CLASS || found_class == type.type_class ||
                        (type.bool_enum && found_class == H5T_ENUM);
  const bool size_ok = type.size != 0
                           ? found_size == type.size
                           : found_class != H5T_FLOAT || found_size == 4 || found_size == 8;
  if (!class_ok || !size_ok) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": expected ", type.name, ", found ", DescribeType(file_type.get())));
  }
  Id space = Dataspace(H5Dget_space(dataset->get()));
  *dims = Dimensions(space.get());
  if (static_cast<int>(dims->size()) != rank) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": expected ", rank, " dimension",
                                                   rank == 1 ? "" : "s", " ", shape_description,
                                                   ", found ", dims->size()));
  }
  if (absl::Status status = CheckFiltersAvailable(dataset->get(), where); !status.ok()) {
    return status;
  }
  return dataset;
}

absl::Status CheckShape(absl::string_view where, const std::vector<hsize_t>& dims,
                        const std::vector<hsize_t>& expected, absl::string_view description) {
  if (dims == expected) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(where, ": expected shape ", description, " = ",
                                                 DimensionsToString(expected), ", found ",
                                                 DimensionsToString(dims)));
}

absl::Status CheckImageSize(absl::string_view where, uint64_t height, uint64_t width) {
  if (height == 0 || width == 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ": expected a non-empty image, found height ", height, " and width ", width));
  }
  constexpr uint64_t kMax = kMaxImagePixels;
  // Each factor is checked first, so that the product cannot overflow.
  if (height > kMax || width > kMax || height * width > kMax) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": expected at most ", kMaxImagePixels,
                                                   " pixels per image, found ", height, " x ",
                                                   width));
  }
  return absl::OkStatus();
}

absl::Status CheckFiltersAvailable(hid_t dataset, absl::string_view where) {
  Id creation = PropertyList(H5Dget_create_plist(dataset));
  const int filters = H5Pget_nfilters(creation.get());
  for (int i = 0; i < filters; ++i) {
    unsigned flags = 0, config = 0;
    size_t values = 0;
    char name[64] = {};
    const H5Z_filter_t filter =
        H5Pget_filter2(creation.get(), i, &flags, &values, nullptr, sizeof name, name, &config);
    if (filter >= 0 && H5Zfilter_avail(filter) <= 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          where, ": stored with HDF5 filter ", filter, " (", name,
          ") which this HDF5 library cannot decode; rewrite it uncompressed or with gzip"));
    }
  }
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// Attributes

namespace {

// Opens attribute `name`: InvalidArgument when it is missing, DataLoss when HDF5 cannot open it.
absl::StatusOr<Id> OpenAttribute(hid_t object, const char* name, absl::string_view where) {
  if (H5Aexists(object, name) <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": missing attribute ", name));
  }
  Id attribute = Attribute(H5Aopen(object, name, H5P_DEFAULT));
  if (!attribute.valid()) {
    return absl::DataLossError(absl::StrCat(where, ": attribute ", name, ": cannot be opened"));
  }
  return attribute;
}

// Opens attribute `name` and checks that it holds exactly one element.
absl::StatusOr<Id> OpenSingleValuedAttribute(hid_t object, const char* name,
                                             absl::string_view where) {
  absl::StatusOr<Id> attribute = OpenAttribute(object, name, where);
  if (!attribute.ok()) return attribute.status();
  Id space = Dataspace(H5Aget_space(attribute->get()));
  const hssize_t points = H5Sget_simple_extent_npoints(space.get());
  if (points != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute ", name, ": expected a single value, found ",
                     DimensionsToString(Dimensions(space.get())), " values"));
  }
  return attribute;
}

absl::Status AttributeReadFailed(const char* name, absl::string_view where) {
  return absl::DataLossError(absl::StrCat(where, ": attribute ", name, ": cannot be read"));
}

}  // namespace

absl::StatusOr<std::string> ReadStringAttribute(hid_t object, const char* name,
                                                absl::string_view where) {
  absl::StatusOr<Id> attribute = OpenSingleValuedAttribute(object, name, where);
  if (!attribute.ok()) return attribute.status();
  Id file_type = Datatype(H5Aget_type(attribute->get()));
  if (H5Tget_class(file_type.get()) != H5T_STRING) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ": attribute ", name, ": expected a string, found ", DescribeType(file_type.get())));
  }
  std::string value;
  if (H5Tis_variable_str(file_type.get()) > 0) {
    Id memory_type = Datatype(H5Tcopy(H5T_C_S1));
    H5Tset_size(memory_type.get(), H5T_VARIABLE);
    H5Tset_cset(memory_type.get(), H5Tget_cset(file_type.get()));
    char* text = nullptr;
    if (H5Aread(attribute->get(), memory_type.get(), &text) < 0) {
      return AttributeReadFailed(name, where);
    }
    if (text != nullptr) value = text;
    H5free_memory(text);
  } else {
    // Same size, padding and character set as stored: HDF5 copies the bytes unchanged.
    Id memory_type = Datatype(H5Tcopy(file_type.get()));
    std::string buffer(H5Tget_size(file_type.get()), '\0');
    if (H5Aread(attribute->get(), memory_type.get(), buffer.data()) < 0) {
      return AttributeReadFailed(name, where);
    }
    value = buffer.substr(0, buffer.find('\0'));
    value.erase(value.find_last_not_of(' ') + 1);
  }
  return value;
}

absl::StatusOr<double> ReadNumericAttribute(hid_t object, const char* name,
                                            absl::string_view where) {
  absl::StatusOr<Id> attribute = OpenSingleValuedAttribute(object, name, where);
  if (!attribute.ok()) return attribute.status();
  Id file_type = Datatype(H5Aget_type(attribute->get()));
  const H5T_class_t type_class = H5Tget_class(file_type.get());
  if (type_class != H5T_FLOAT && type_class != H5T_INTEGER) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": attribute ", name,
                                                   ": expected a number (float64), found ",
                                                   DescribeType(file_type.get())));
  }
  double value = 0.0;
  if (H5Aread(attribute->get(), H5T_NATIVE_DOUBLE, &value) < 0) {
    return AttributeReadFailed(name, where);
  }
  return value;
}

absl::StatusOr<double> ReadFiniteAttribute(hid_t object, const char* name, absl::string_view where,
                                           Sign sign) {
  absl::StatusOr<double> value = ReadNumericAttribute(object, name, where);
  if (!value.ok()) return value.status();
  const bool ok =
      std::isfinite(*value) && (sign == Sign::kAny || (sign == Sign::kPositive && *value > 0) ||
                                (sign == Sign::kNonNegative && *value >= 0));
  if (!ok) {
    const char* rule = sign == Sign::kPositive      ? "a finite value > 0"
                       : sign == Sign::kNonNegative ? "a finite value >= 0"
                                                    : "a finite value";
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute ", name, ": expected ", rule, ", found ", *value));
  }
  return value;
}

absl::StatusOr<int64_t> ReadIntegerAttribute(hid_t object, const char* name,
                                             absl::string_view where, int64_t min, int64_t max) {
  absl::StatusOr<double> value = ReadNumericAttribute(object, name, where);
  if (!value.ok()) return value.status();
  if (!(*value >= static_cast<double>(min) && *value <= static_cast<double>(max)) ||
      std::floor(*value) != *value) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": attribute ", name,
                                                   ": expected an integer in ", min, "..", max,
                                                   ", found ", *value));
  }
  return static_cast<int64_t>(*value);
}

absl::StatusOr<std::vector<double>> ReadDoubleArrayAttribute(hid_t object, const char* name,
                                                             absl::string_view where,
                                                             size_t length) {
  absl::StatusOr<Id> attribute = OpenAttribute(object, name, where);
  if (!attribute.ok()) return attribute.status();
  Id type = Datatype(H5Aget_type(attribute->get()));
  Id space = Dataspace(H5Aget_space(attribute->get()));
  const std::vector<hsize_t> dims = Dimensions(space.get());
  const H5T_class_t type_class = H5Tget_class(type.get());
  if ((type_class != H5T_FLOAT && type_class != H5T_INTEGER) || dims.size() != 1 ||
      dims[0] != length) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute ", name, ": expected ", length, " float64 values, found ",
                     DescribeType(type.get()), " ", DimensionsToString(dims)));
  }
  std::vector<double> values(length);
  if (H5Aread(attribute->get(), H5T_NATIVE_DOUBLE, values.data()) < 0) {
    return AttributeReadFailed(name, where);
  }
  return values;
}

namespace {

absl::Status WriteAttribute(hid_t object, const char* name, hid_t file_type, hid_t space,
                            hid_t memory_type, const void* value) {
  if (H5Aexists(object, name) > 0) H5Adelete(object, name);
  Id attribute = Attribute(H5Acreate2(object, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT));
  if (!attribute.valid() || H5Awrite(attribute.get(), memory_type, value) < 0) {
    return absl::InternalError(absl::StrCat("cannot write attribute ", name));
  }
  return attribute.Close();
}

absl::Status WriteScalarAttribute(hid_t object, const char* name, hid_t file_type,
                                  hid_t memory_type, const void* value) {
  Id space = Dataspace(H5Screate(H5S_SCALAR));
  return WriteAttribute(object, name, file_type, space.get(), memory_type, value);
}

}  // namespace

absl::Status WriteStringAttribute(hid_t object, const char* name, absl::string_view value) {
  Id type = Datatype(H5Tcopy(H5T_C_S1));
  H5Tset_size(type.get(), H5T_VARIABLE);
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  const std::string text(value);
  const char* pointer = text.c_str();
  return WriteScalarAttribute(object, name, type.get(), type.get(), &pointer);
}

absl::Status WriteDoubleAttribute(hid_t object, const char* name, double value) {
  return WriteScalarAttribute(object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value);
}

absl::Status WriteInt64Attribute(hid_t object, const char* name, int64_t value) {
  return WriteScalarAttribute(object, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &value);
}

absl::Status WriteDoubleArrayAttribute(hid_t object, const char* name,
                                       const std::vector<double>& values) {
  const hsize_t length = values.size();
  Id space = Dataspace(H5Screate_simple(1, &length, nullptr));
  return WriteAttribute(object, name, H5T_IEEE_F64LE, space.get(), H5T_NATIVE_DOUBLE,
                        values.data());
}

// ---------------------------------------------------------------------------------------------
// Datasets

absl::StatusOr<Id> CreateDataset(hid_t parent, const char* name, hid_t file_type,
                                 const DatasetLayout& layout) {
  const auto failed = [&] {
    return absl::InternalError(absl::StrCat("cannot create dataset ", name));
  };
  const int rank = static_cast<int>(layout.dims.size());
  if ((!layout.max_dims.empty() && layout.max_dims.size() != layout.dims.size()) ||
      (!layout.chunk.empty() && layout.chunk.size() != layout.dims.size()) ||
      (layout.deflate_level != 0 && layout.chunk.empty())) {
    return failed();
  }
  Id space = Dataspace(H5Screate_simple(
      rank, layout.dims.data(), layout.max_dims.empty() ? nullptr : layout.max_dims.data()));
  Id creation = PropertyList(H5Pcreate(H5P_DATASET_CREATE));
  if (!space.valid() || !creation.valid()) return failed();
  if (!layout.chunk.empty() && H5Pset_chunk(creation.get(), rank, layout.chunk.data()) < 0) {
    return failed();
  }
  if (layout.deflate_level != 0 && (H5Pset_shuffle(creation.get()) < 0 ||
                                    H5Pset_deflate(creation.get(), layout.deflate_level) < 0)) {
    return failed();
  }
  if (layout.fill != nullptr &&
      H5Pset_fill_value(creation.get(), layout.fill_type, layout.fill) < 0) {
    return failed();
  }
  Id dataset = Dataset(
      H5Dcreate2(parent, name, file_type, space.get(), H5P_DEFAULT, creation.get(), H5P_DEFAULT));
  if (!dataset.valid()) return failed();
  return dataset;
}

absl::Status WriteDataset(hid_t parent, const char* name, hid_t file_type, hid_t memory_type,
                          const std::vector<hsize_t>& dims, const void* data) {
  absl::StatusOr<Id> dataset = CreateDataset(parent, name, file_type, {.dims = dims});
  if (!dataset.ok()) return dataset.status();
  if (H5Dwrite(dataset->get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    return absl::InternalError(absl::StrCat("cannot write dataset ", name));
  }
  return dataset->Close();
}

absl::Status ReadDataset(hid_t dataset, hid_t memory_type, void* data, absl::string_view where) {
  if (H5Dread(dataset, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    return absl::DataLossError(absl::StrCat(where, ": cannot be read (corrupt or truncated file)"));
  }
  return absl::OkStatus();
}

namespace {

// The file and memory dataspaces of the block [start, start + count) of `dataset`.
bool SelectBlock(hid_t dataset, const std::vector<hsize_t>& start,
                 const std::vector<hsize_t>& count, Id* file_space, Id* memory_space) {
  *file_space = Dataspace(H5Dget_space(dataset));
  *memory_space =
      Dataspace(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr));
  return file_space->valid() && memory_space->valid() && start.size() == count.size() &&
         H5Sget_simple_extent_ndims(file_space->get()) == static_cast<int>(count.size()) &&
         H5Sselect_hyperslab(file_space->get(), H5S_SELECT_SET, start.data(), nullptr, count.data(),
                             nullptr) >= 0;
}

}  // namespace

absl::Status ReadBlock(hid_t dataset, const std::vector<hsize_t>& start,
                       const std::vector<hsize_t>& count, hid_t memory_type, void* data) {
  Id file_space, memory_space;
  if (!SelectBlock(dataset, start, count, &file_space, &memory_space) ||
      H5Dread(dataset, memory_type, memory_space.get(), file_space.get(), H5P_DEFAULT, data) < 0) {
    return absl::DataLossError(absl::StrCat("HDF5 cannot read the block at ",
                                            DimensionsToString(start), " of ",
                                            DimensionsToString(count)));
  }
  return absl::OkStatus();
}

absl::Status WriteBlock(hid_t dataset, const std::vector<hsize_t>& start,
                        const std::vector<hsize_t>& count, hid_t memory_type, const void* data) {
  Id file_space, memory_space;
  if (!SelectBlock(dataset, start, count, &file_space, &memory_space) ||
      H5Dwrite(dataset, memory_type, memory_space.get(), file_space.get(), H5P_DEFAULT, data) < 0) {
    return absl::InternalError(absl::StrCat("HDF5 cannot write the block at ",
                                            DimensionsToString(start), " of ",
                                            DimensionsToString(count)));
  }
  return absl::OkStatus();
}

absl::Status AppendAlongFirst(hid_t dataset, hsize_t index, hid_t memory_type, const void* data) {
  Id space = Dataspace(H5Dget_space(dataset));
  std::vector<hsize_t> dims = Dimensions(space.get());
  if (dims.empty()) return absl::InternalError("cannot append to a scalar dataset");
  dims[0] = index + 1;
  if (H5Dset_extent(dataset, dims.data()) < 0) {
    return absl::InternalError(absl::StrCat("cannot extend the dataset to ", index + 1));
  }
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = index;
  count[0] = 1;
  return WriteBlock(dataset, start, count, memory_type, data);
}

}  // namespace transient::h5
