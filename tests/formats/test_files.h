// HDF5 files for and from the tool's tests: moment files written directly through HDF5's C API
// (not through the code under test), edits that break one rule of the layout, and readers of
// the products the tool writes.
#pragma once

#include <hdf5.h>

#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "transient/reconstruct/image.h"

namespace transient::tools::testing {

// Moments of a stack of frames in double precision, the layout of the file:
// real[((frame * (m+1)) + j) * pixels + pixel].
struct MomentStack {
  int frames = 0;
  int order = 0;
  ImageGeometry geometry;
  double base_frequency_hz = 23e6;
  std::vector<double> real, imag;
  std::vector<uint8_t> valid;  // empty or frames * pixels

  MomentStack(int frames, int order, ImageGeometry geometry);
  int64_t index(int frame, int j, int64_t pixel) const {
    return (int64_t{frame} * (order + 1) + j) * geometry.pixel_count() + pixel;
  }
};

enum class StoredFloat { kFloat32, kFloat64 };
enum class StoredString { kVariableLength, kFixedLength };

// Names in test output ("GetParam() = (float32, true)").
inline void PrintTo(StoredFloat type, std::ostream* os) {
  *os << (type == StoredFloat::kFloat32 ? "float32" : "float64");
}

struct WriteOptions {
  StoredFloat type = StoredFloat::kFloat32;
  StoredString format_string = StoredString::kVariableLength;
  std::string format = "transient-moments 1";
  bool write_valid = true;  // write /moments/valid when the stack has a mask
};

// Writes `stack` in the documented layout. Fails the current test on any HDF5 error.
void WriteMomentFile(const std::string& path, const MomentStack& stack,
                     const WriteOptions& options = {});

// A small valid file: 2 frames, m = 3, 4x3 px, float32, with a mask.
void WriteSmallMomentFile(const std::string& path);

// Edits of an existing file, each breaking (or setting) exactly one thing.
void DeleteObject(const std::string& path, const std::string& object);
// Replaces (or creates) a dataset of the given file type and shape, filled with zeros.
void ReplaceDataset(const std::string& path, const std::string& object, hid_t file_type,
                    const std::vector<hsize_t>& dims);
// Replaces (or creates) a chunked float32 dataset of the given shape without writing any of
// it: a file of a few kB can declare an image far larger than memory.
void ReplaceWithUnwrittenDataset(const std::string& path, const std::string& object,
                                 const std::vector<hsize_t>& dims);
// Replaces (or creates) a float32 dataset stored in the external raw file `external` (which
// need not exist): the layout checks pass, the first read fails.
void ReplaceWithExternalDataset(const std::string& path, const std::string& object,
                                const std::vector<hsize_t>& dims, const std::string& external);
void SetStringAttribute(const std::string& path, const std::string& object, const std::string& name,
                        const std::string& value,
                        StoredString kind = StoredString::kVariableLength);
void SetDoubleAttribute(const std::string& path, const std::string& object, const std::string& name,
                        double value);
void DeleteAttribute(const std::string& path, const std::string& object, const std::string& name);

// Reads a whole float32-convertible dataset of `path` (fails the test if it cannot).
std::vector<float> ReadFloatDataset(const std::string& path, const std::string& object,
                                    std::vector<hsize_t>* dims = nullptr);
std::vector<uint8_t> ReadUint8Dataset(const std::string& path, const std::string& object,
                                      std::vector<hsize_t>* dims = nullptr);
bool ObjectExists(const std::string& path, const std::string& object);
// Scalar attributes of the root group.
std::string ReadRootStringAttribute(const std::string& path, const std::string& name);
double ReadRootDoubleAttribute(const std::string& path, const std::string& name);

}  // namespace transient::tools::testing
