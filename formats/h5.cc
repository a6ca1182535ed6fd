// RAII and attribute helpers over HDF5's C API.
#include "transient/formats/h5.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"

namespace transient::h5 {

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

namespace {

// Opens attribute `name` and checks that it holds exactly one element.
absl::StatusOr<Id> OpenSingleValuedAttribute(hid_t object, const char* name,
                                             absl::string_view where) {
  if (H5Aexists(object, name) <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": missing attribute ", name));
  }
  Id attribute = Attribute(H5Aopen(object, name, H5P_DEFAULT));
  if (!attribute.valid()) {
    return absl::DataLossError(absl::StrCat(where, ": attribute ", name, ": cannot be opened"));
  }
  Id space = Dataspace(H5Aget_space(attribute.get()));
  const hssize_t points = H5Sget_simple_extent_npoints(space.get());
  if (points != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute ", name, ": expected a single value, found ",
                     DimensionsToString(Dimensions(space.get())), " values"));
  }
  return attribute;
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
  const auto read_failed = [&] {
    return absl::DataLossError(absl::StrCat(where, ": attribute ", name, ": cannot be read"));
  };
  std::string value;
  if (H5Tis_variable_str(file_type.get()) > 0) {
    Id memory_type = Datatype(H5Tcopy(H5T_C_S1));
    H5Tset_size(memory_type.get(), H5T_VARIABLE);
    H5Tset_cset(memory_type.get(), H5Tget_cset(file_type.get()));
    char* text = nullptr;
    if (H5Aread(attribute->get(), memory_type.get(), &text) < 0) return read_failed();
    if (text != nullptr) value = text;
    H5free_memory(text);
  } else {
    // Same size, padding and character set as stored: HDF5 copies the bytes unchanged.
    Id memory_type = Datatype(H5Tcopy(file_type.get()));
    std::string buffer(H5Tget_size(file_type.get()), '\0');
    if (H5Aread(attribute->get(), memory_type.get(), buffer.data()) < 0) return read_failed();
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
    return absl::DataLossError(absl::StrCat(where, ": attribute ", name, ": cannot be read"));
  }
  return value;
}

namespace {

absl::Status WriteScalarAttribute(hid_t object, const char* name, hid_t file_type,
                                  hid_t memory_type, const void* value) {
  Id space = Dataspace(H5Screate(H5S_SCALAR));
  if (H5Aexists(object, name) > 0) H5Adelete(object, name);
  Id attribute =
      Attribute(H5Acreate2(object, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!attribute.valid() || H5Awrite(attribute.get(), memory_type, value) < 0) {
    return absl::InternalError(absl::StrCat("cannot write attribute ", name));
  }
  return attribute.Close();
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
    const std::string message = absl::StrCat(path, ": cannot be read (", std::strerror(reason), ")");
    return reason == EACCES ? absl::PermissionDeniedError(message)
                            : absl::InvalidArgumentError(message);
  }
  std::fclose(stream);
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": not an HDF5 file"));
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

absl::StatusOr<Id> OpenObject(hid_t file, absl::string_view file_path, const std::string& object,
                              H5I_type_t kind, absl::string_view description) {
  const std::string where = absl::StrCat(file_path, ": ", object);
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

}  // namespace transient::h5
