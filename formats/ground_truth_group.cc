// The /ground_truth group of captures: checks, writer and reader.
#include "ground_truth_group.h"

#include <algorithm>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "transient/formats/h5.h"
#include "transient/reconstruct/moments.h"

namespace transient {
namespace {

using h5::Where;

}  // namespace

absl::Status CheckGroundTruth(const GroundTruth& truth, ImageGeometry camera) {
  const size_t pixels = static_cast<size_t>(camera.pixel_count());
  const size_t returns = static_cast<size_t>(std::max(truth.max_returns, 0)) * pixels;
  const int m = truth.moments.order;
  const size_t moments = static_cast<size_t>(m + 1) * pixels;
  if (!(truth.geometry == camera) || !(truth.moments.geometry == camera)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "ground truth geometry = ", truth.geometry.width, "x", truth.geometry.height, ", moments ",
        truth.moments.geometry.width, "x", truth.moments.geometry.height,
        ". Violated constraint: both are the camera's ", camera.width, "x", camera.height));
  }
  if (truth.max_returns < 0 || m < 1 || m > kMaxOrder || truth.first_range_m.size() != pixels ||
      truth.return_range_m.size() != returns || truth.return_amplitude.size() != returns ||
      truth.return_spread_m.size() != returns || truth.moments.real.size() != moments ||
      truth.moments.imag.size() != moments) {
    return absl::InvalidArgumentError(
        absl::StrCat("ground truth max_returns = ", truth.max_returns, ", order = ", m,
                     ". Violated constraint: max_returns >= 0, 1 <= order <= ", kMaxOrder,
                     ", first_range_m holds H*W values, return_* R*H*W, moments (m+1)*H*W"));
  }
  return absl::OkStatus();
}

absl::Status WriteGroundTruthGroup(hid_t group, const GroundTruth& truth) {
  const hsize_t h = truth.geometry.height, w = truth.geometry.width;
  const hsize_t r = truth.max_returns, m1 = truth.moments.order + 1;
  absl::Status status = h5::WriteDataset(group, "first_range_m", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT,
                                         {h, w}, truth.first_range_m.data());
  for (auto [name, data] : {std::pair{"return_range_m", &truth.return_range_m},
                            std::pair{"return_amplitude", &truth.return_amplitude},
                            std::pair{"return_spread_m", &truth.return_spread_m}}) {
    status.Update(
        h5::WriteDataset(group, name, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, {r, h, w}, data->data()));
  }
  if (!status.ok()) return status;
  h5::Id moments = h5::Group(H5Gcreate2(group, "moments", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!moments.valid()) return absl::InternalError("cannot create group moments");
  status.Update(h5::WriteDataset(moments.get(), "real", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT,
                                 {m1, h, w}, truth.moments.real.data()));
  status.Update(h5::WriteDataset(moments.get(), "imag", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT,
                                 {m1, h, w}, truth.moments.imag.data()));
  return status;
}

absl::StatusOr<GroundTruth> ReadGroundTruthGroup(hid_t file, const std::string& path,
                                                 ImageGeometry camera) {
  GroundTruth truth;
  truth.geometry = camera;
  const hsize_t h = camera.height, w = camera.width;
  std::vector<hsize_t> dims;
  const auto read_plane = [&](const std::string& object, const std::vector<hsize_t>& expected,
                              const char* description, std::vector<float>* out) -> absl::Status {
    absl::StatusOr<h5::Id> dataset = h5::OpenDataset(
        file, path, object, h5::kAnyFloat, static_cast<int>(expected.size()), description, &dims);
    if (!dataset.ok()) return dataset.status();
    if (absl::Status status = h5::CheckShape(Where(path, object), dims, expected, description);
        !status.ok()) {
      return status;
    }
    size_t count = 1;
    for (hsize_t d : dims) count *= d;
    out->resize(count);
    return h5::ReadDataset(dataset->get(), H5T_NATIVE_FLOAT, out->data(), Where(path, object));
  };
  if (absl::Status status = read_plane("/ground_truth/first_range_m", {h, w}, "[height, width]",
                                       &truth.first_range_m);
      !status.ok()) {
    return status;
  }
  // R comes from return_range_m; the other two must agree with it.
  {
    absl::StatusOr<h5::Id> probe =
        h5::OpenDataset(file, path, "/ground_truth/return_range_m", h5::kAnyFloat, 3,
                        "[returns, height, width]", &dims);
    if (!probe.ok()) return probe.status();
    truth.max_returns = static_cast<int>(std::min<hsize_t>(dims[0], 1 << 20));
  }
  const hsize_t r = truth.max_returns;
  for (auto [object, out] : {std::pair{"/ground_truth/return_range_m", &truth.return_range_m},
                             std::pair{"/ground_truth/return_amplitude", &truth.return_amplitude},
                             std::pair{"/ground_truth/return_spread_m", &truth.return_spread_m}}) {
    if (absl::Status status = read_plane(object, {r, h, w}, "[returns, height, width]", out);
        !status.ok()) {
      return status;
    }
  }
  {
    absl::StatusOr<h5::Id> probe = h5::OpenDataset(file, path, "/ground_truth/moments/real",
                                                   h5::kAnyFloat, 3, "[m+1, height, width]", &dims);
    if (!probe.ok()) return probe.status();
    if (dims[0] < 2 || dims[0] > static_cast<hsize_t>(kMaxMoments)) {
      return absl::InvalidArgumentError(absl::StrCat(Where(path, "/ground_truth/moments/real"),
                                                     ": expected m+1 = 2..", kMaxMoments,
                                                     " moments in dimension 1, found ", dims[0]));
    }
  }
  const hsize_t m1 = dims[0];
  truth.moments.geometry = camera;
  truth.moments.order = static_cast<int>(m1) - 1;
  for (auto [object, out] : {std::pair{"/ground_truth/moments/real", &truth.moments.real},
                             std::pair{"/ground_truth/moments/imag", &truth.moments.imag}}) {
    if (absl::Status status = read_plane(object, {m1, h, w}, "[m+1, height, width]", out);
        !status.ok()) {
      return status;
    }
  }
  return truth;
}

}  // namespace transient
