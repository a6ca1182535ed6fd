// Moment files, edits and product readers over HDF5's C API for the tool's tests.
#include "tests/formats/test_files.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "transient/formats/h5.h"

namespace transient::tools::testing {
namespace {

using h5::Id;

Id OpenForWriting(const std::string& path) {
  h5::SilenceErrorStack();
  Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  EXPECT_TRUE(file.valid()) << "cannot open " << path;
  return file;
}

void WriteDataset(hid_t location, const char* name, hid_t file_type, hid_t memory_type,
                  const std::vector<hsize_t>& dims, const void* data) {
  Id space = h5::Dataspace(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
  Id dataset = h5::Dataset(
      H5Dcreate2(location, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  ASSERT_TRUE(dataset.valid()) << "cannot create " << name;
  ASSERT_GE(H5Dwrite(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0);
}

void WriteString(hid_t object, const std::string& name, const std::string& value,
                 StoredString kind) {
  if (H5Aexists(object, name.c_str()) > 0) H5Adelete(object, name.c_str());
  Id type = h5::Datatype(H5Tcopy(H5T_C_S1));
  Id space = h5::Dataspace(H5Screate(H5S_SCALAR));
  if (kind == StoredString::kVariableLength) {
    H5Tset_size(type.get(), H5T_VARIABLE);
    H5Tset_cset(type.get(), H5T_CSET_UTF8);
    Id attribute = h5::Attribute(
        H5Acreate2(object, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT));
    const char* text = value.c_str();
    ASSERT_GE(H5Awrite(attribute.get(), type.get(), &text), 0);
  } else {
    // As MATLAB's h5writeatt does: fixed length, NUL-terminated, ASCII.
    H5Tset_size(type.get(), value.size() + 1);
    H5Tset_strpad(type.get(), H5T_STR_NULLTERM);
    Id attribute = h5::Attribute(
        H5Acreate2(object, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT));
    ASSERT_GE(H5Awrite(attribute.get(), type.get(), value.c_str()), 0);
  }
}

void WriteDouble(hid_t object, const std::string& name, double value) {
  if (H5Aexists(object, name.c_str()) > 0) H5Adelete(object, name.c_str());
  Id space = h5::Dataspace(H5Screate(H5S_SCALAR));
  Id attribute = h5::Attribute(
      H5Acreate2(object, name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT));
  ASSERT_GE(H5Awrite(attribute.get(), H5T_NATIVE_DOUBLE, &value), 0);
}

}  // namespace

MomentStack::MomentStack(int frames, int order, ImageGeometry geometry)
    : frames(frames),
      order(order),
      geometry(geometry),
      real(static_cast<size_t>(frames) * (order + 1) * geometry.pixel_count(), 0.0),
      imag(real.size(), 0.0) {}

void WriteMomentFile(const std::string& path, const MomentStack& stack,
                     const WriteOptions& options) {
  h5::SilenceErrorStack();
  Id file = h5::File(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  ASSERT_TRUE(file.valid()) << "cannot create " << path;
  WriteString(file.get(), "format", options.format, options.format_string);
  Id group = h5::Group(H5Gcreate2(file.get(), "moments", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  ASSERT_TRUE(group.valid());
  WriteDouble(group.get(), "base_frequency_hz", stack.base_frequency_hz);
  const std::vector<hsize_t> dims = {
      static_cast<hsize_t>(stack.frames), static_cast<hsize_t>(stack.order + 1),
      static_cast<hsize_t>(stack.geometry.height), static_cast<hsize_t>(stack.geometry.width)};
  for (auto [name, values] : {std::pair{"real", &stack.real}, std::pair{"imag", &stack.imag}}) {
    if (options.type == StoredFloat::kFloat64) {
      WriteDataset(group.get(), name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, dims, values->data());
    } else {
      const std::vector<float> narrow(values->begin(), values->end());
      WriteDataset(group.get(), name, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, dims, narrow.data());
    }
  }
  if (options.write_valid && !stack.valid.empty()) {
    WriteDataset(group.get(), "valid", H5T_STD_U8LE, H5T_NATIVE_UINT8, {dims[0], dims[2], dims[3]},
                 stack.valid.data());
  }
}

void WriteSmallMomentFile(const std::string& path) {
  MomentStack stack(2, 3, {.width = 4, .height = 3});
  const int64_t pixels = stack.geometry.pixel_count();
  for (int frame = 0; frame < stack.frames; ++frame) {
    for (int64_t p = 0; p < pixels; ++p) {
      // One return at a phase that varies over the image: c_j = exp(i j phi).
      const double phase = 0.5 + 0.1 * p + 0.3 * frame;
      for (int j = 0; j <= stack.order; ++j) {
        stack.real[stack.index(frame, j, p)] = std::cos(j * phase);
        stack.imag[stack.index(frame, j, p)] = std::sin(j * phase);
      }
    }
  }
  stack.valid.assign(stack.frames * pixels, 1);
  WriteMomentFile(path, stack);
}

void DeleteObject(const std::string& path, const std::string& object) {
  Id file = OpenForWriting(path);
  ASSERT_GE(H5Ldelete(file.get(), object.c_str(), H5P_DEFAULT), 0) << object;
}

void ReplaceDataset(const std::string& path, const std::string& object, hid_t file_type,
                    const std::vector<hsize_t>& dims) {
  Id file = OpenForWriting(path);
  if (H5Lexists(file.get(), object.c_str(), H5P_DEFAULT) > 0) {
    ASSERT_GE(H5Ldelete(file.get(), object.c_str(), H5P_DEFAULT), 0);
  }
  hsize_t count = 1;
  for (hsize_t d : dims) count *= d;
  const std::vector<double> zeros(count, 0.0);
  // HDF5 converts the doubles to whatever numeric file type is asked for.
  WriteDataset(file.get(), object.c_str(), file_type, H5T_NATIVE_DOUBLE, dims, zeros.data());
}

namespace {

void CreateEmptyDataset(const std::string& path, const std::string& object,
                        const std::vector<hsize_t>& dims, hid_t creation) {
  Id file = OpenForWriting(path);
  if (H5Lexists(file.get(), object.c_str(), H5P_DEFAULT) > 0) {
    ASSERT_GE(H5Ldelete(file.get(), object.c_str(), H5P_DEFAULT), 0);
  }
  Id space = h5::Dataspace(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
  Id dataset = h5::Dataset(H5Dcreate2(file.get(), object.c_str(), H5T_IEEE_F32LE, space.get(),
                                      H5P_DEFAULT, creation, H5P_DEFAULT));
  ASSERT_TRUE(dataset.valid()) << object;
}

}  // namespace

void ReplaceWithUnwrittenDataset(const std::string& path, const std::string& object,
                                 const std::vector<hsize_t>& dims) {
  std::vector<hsize_t> chunk(dims.size(), 1);
  for (size_t d = dims.size() - 2; d < dims.size(); ++d) chunk[d] = std::min<hsize_t>(dims[d], 256);
  Id creation = h5::PropertyList(H5Pcreate(H5P_DATASET_CREATE));
  ASSERT_GE(H5Pset_chunk(creation.get(), static_cast<int>(chunk.size()), chunk.data()), 0);
  CreateEmptyDataset(path, object, dims, creation.get());
}

void ReplaceWithExternalDataset(const std::string& path, const std::string& object,
                                const std::vector<hsize_t>& dims, const std::string& external) {
  Id creation = h5::PropertyList(H5Pcreate(H5P_DATASET_CREATE));
  ASSERT_GE(H5Pset_external(creation.get(), external.c_str(), 0, H5F_UNLIMITED), 0);
  CreateEmptyDataset(path, object, dims, creation.get());
}

void SetStringAttribute(const std::string& path, const std::string& object, const std::string& name,
                        const std::string& value, StoredString kind) {
  Id file = OpenForWriting(path);
  Id target = h5::Object(H5Oopen(file.get(), object.c_str(), H5P_DEFAULT));
  ASSERT_TRUE(target.valid()) << object;
  WriteString(target.get(), name, value, kind);
}

void SetDoubleAttribute(const std::string& path, const std::string& object, const std::string& name,
                        double value) {
  Id file = OpenForWriting(path);
  Id target = h5::Object(H5Oopen(file.get(), object.c_str(), H5P_DEFAULT));
  ASSERT_TRUE(target.valid()) << object;
  WriteDouble(target.get(), name, value);
}

void DeleteAttribute(const std::string& path, const std::string& object, const std::string& name) {
  Id file = OpenForWriting(path);
  ASSERT_GE(H5Adelete_by_name(file.get(), object.c_str(), name.c_str(), H5P_DEFAULT), 0)
      << object << " " << name;
}

namespace {

template <typename T>
std::vector<T> ReadDataset(const std::string& path, const std::string& object, hid_t memory_type,
                           std::vector<hsize_t>* dims) {
  h5::SilenceErrorStack();
  Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  EXPECT_TRUE(file.valid()) << "cannot open " << path;
  if (!file.valid()) return {};
  Id dataset = h5::Dataset(H5Dopen2(file.get(), object.c_str(), H5P_DEFAULT));
  EXPECT_TRUE(dataset.valid()) << path << " has no dataset " << object;
  if (!dataset.valid()) return {};
  Id space = h5::Dataspace(H5Dget_space(dataset.get()));
  const std::vector<hsize_t> shape = h5::Dimensions(space.get());
  if (dims != nullptr) *dims = shape;
  std::vector<T> values(H5Sget_simple_extent_npoints(space.get()));
  EXPECT_GE(H5Dread(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), 0);
  return values;
}

}  // namespace

std::vector<float> ReadFloatDataset(const std::string& path, const std::string& object,
                                    std::vector<hsize_t>* dims) {
  return ReadDataset<float>(path, object, H5T_NATIVE_FLOAT, dims);
}

std::vector<uint8_t> ReadUint8Dataset(const std::string& path, const std::string& object,
                                      std::vector<hsize_t>* dims) {
  return ReadDataset<uint8_t>(path, object, H5T_NATIVE_UINT8, dims);
}

bool ObjectExists(const std::string& path, const std::string& object) {
  h5::SilenceErrorStack();
  Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  return file.valid() && h5::LinkExists(file.get(), object);
}

std::string ReadRootStringAttribute(const std::string& path, const std::string& name) {
  h5::SilenceErrorStack();
  Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  absl::StatusOr<std::string> value = h5::ReadStringAttribute(file.get(), name.c_str(), path);
  EXPECT_TRUE(value.ok()) << value.status();
  return value.value_or("");
}

double ReadRootDoubleAttribute(const std::string& path, const std::string& name) {
  h5::SilenceErrorStack();
  Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  absl::StatusOr<double> value = h5::ReadNumericAttribute(file.get(), name.c_str(), path);
  EXPECT_TRUE(value.ok()) << value.status();
  return value.value_or(std::nan(""));
}

}  // namespace transient::tools::testing
