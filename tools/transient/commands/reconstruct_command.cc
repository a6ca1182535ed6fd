// The reconstruct command: read a frame, solve it, write its products, repeat.
#include "tools/transient/commands/reconstruct_command.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <new>
#include <span>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/formats/moment_file.h"
#include "transient/formats/reconstruction_file.h"
#include "transient/formats/atomic_output.h"
#include "transient/reconstruct/frame_products.h"
#include "transient/reconstruct/status_context.h"

namespace transient::tools {
namespace {

bool HasMese(Method method) { return method != Method::kPisarenko; }
bool HasPisarenko(Method method) { return method != Method::kMese; }

// Adds `file`'s name to a status from a component that does not know it.
// Per-frame working buffers, allocated once for the whole run.
struct FrameBuffers {
  MomentImage moments;
  std::vector<float> block;          // a block of bins planes
  std::vector<float> second_block;   // a block of bins planes
};

struct FrameCounts {
  int64_t biased = 0, invalid = 0, no_return = 0;
};

// Writes a bins-planes product computed by `compute(phases, out)` a block of bins at a time.
template <typename Compute>
absl::Status WriteBinBlocks(ReconstructionFile& file, Product product, int64_t frame,
                            std::span<const double> phases, int64_t bins_per_block, int64_t pixels,
                            std::vector<float>& block, Compute compute) {
  for (int64_t first = 0; first < static_cast<int64_t>(phases.size()); first += bins_per_block) {
    const int64_t count = std::min<int64_t>(bins_per_block, phases.size() - first);
    block.resize(count * pixels);
    compute(phases.subspan(first, count), std::span<float>(block));
    if (absl::Status status = file.Write(product, frame, static_cast<int>(first), block);
        !status.ok()) {
      return status;
    }
  }
  return absl::OkStatus();
}

class FrameReconstructor {
 public:
  FrameReconstructor(const ReconstructArgs& args, double base_frequency_hz,
                     std::vector<double> phases)
      : args_(args), phases_(std::move(phases)) {
    solve_options_.bias_epsilon = args.bias_epsilon;
    solve_options_.bias_mode = args.bias_mode;
    solve_options_.zeroth = args.zeroth;
    range_options_.base_frequency_hz = base_frequency_hz;
    range_options_.threshold = args.threshold;
  }

  absl::Status ValidateOptions() const {
    if (absl::Status status = solve_options_.Validate(); !status.ok()) return status;
    return range_options_.Validate();
  }

  // Reconstructs `moments` and writes its products as output frame `frame`.
  absl::Status Run(const MomentImage& moments, int64_t frame, ReconstructionFile& file,
                   FrameBuffers& buffers, FrameCounts& counts) const;

 private:
  const ReconstructArgs& args_;
  std::vector<double> phases_;
  SolveOptions solve_options_;
  RangeOptions range_options_;
};

absl::Status FrameReconstructor::Run(const MomentImage& moments, int64_t frame,
                                     ReconstructionFile& file, FrameBuffers& buffers,
                                     FrameCounts& counts) const {
  // The frame pipeline's Solve and products (frame_pipeline.h, frame_products.h); /range_m and
  // /flags come from MESE unless only Pisarenko runs.
  const auto solved_image = std::make_shared<SolvedImage>(Solve(moments, solve_options_));
  const SolvedImage& solved = *solved_image;
  const bool pisarenko = HasPisarenko(args_.method);
  const ProductNeeds needs = NeedsOf(args_.method);
  const ProductOptions options = OptionsOf({.method = args_.method,
                                            .base_frequency_hz = range_options_.base_frequency_hz,
                                            .threshold = args_.threshold});
  const std::shared_ptr<const FrameProducts> products =
      ComputeProducts(solved_image, CameraInfo{}, options, needs);
  const int64_t pixels = moments.geometry.pixel_count();
  if (absl::Status s = file.Write(Product::kZerothMoment, frame, 0, products->c0); !s.ok()) {
    return s;
  }
  if (absl::Status s = file.Write(Product::kRange, frame, 0, products->range_m); !s.ok()) return s;
  if (pisarenko) {
    const PisarenkoImage& returns = *products->pisarenko;
    for (auto [product, values] :
         {std::pair{Product::kPisarenkoPhase, &returns.phase},
          std::pair{Product::kPisarenkoWeight, &returns.weight},
          std::pair{Product::kPisarenkoUniform, &returns.uniform},
          std::pair{Product::kPisarenkoRange, &products->pisarenko_range_m},
          std::pair{Product::kPisarenkoDirect, &products->direct},
          std::pair{Product::kPisarenkoIndirect, &products->indirect}}) {
      if (absl::Status s = file.Write(product, frame, 0, *values); !s.ok()) return s;
    }
  }
  if (absl::Status s = file.WriteFlags(frame, products->flags); !s.ok()) return s;
  for (uint8_t f : products->flags) {
    counts.biased += (f & kFlagBiased) != 0;
    counts.invalid += (f & kFlagInvalidInput) != 0;
    counts.no_return += (f & kFlagNoReturn) != 0;
  }

  const int64_t bins = static_cast<int64_t>(phases_.size());
  const int64_t bins_per_block = std::clamp<int64_t>(args_.max_block_values / pixels, 1, bins);
  if (HasMese(args_.method)) {
    for (Product product : {Product::kDensity, Product::kCumulative}) {
      absl::Status status =
          WriteBinBlocks(file, product, frame, phases_, bins_per_block, pixels, buffers.block,
                         [&](std::span<const double> phases, std::span<float> out) {
                           if (product == Product::kDensity) {
                             DensitySlices(solved, phases, out);
                           } else {
                             CumulativeSlices(solved, phases, out);
                           }
                         });
      if (!status.ok()) return status;
    }
  }
  if (args_.bounds_r.has_value()) {
    // Lower and upper bounds come from one call; compute each block once for both datasets.
    for (int64_t first = 0; first < bins; first += bins_per_block) {
      const int64_t count = std::min(bins_per_block, bins - first);
      buffers.block.resize(count * pixels);
      buffers.second_block.resize(count * pixels);
      BoundSlices(solved, *args_.bounds_r, std::span(phases_).subspan(first, count), buffers.block,
                  buffers.second_block);
      const int first_plane = static_cast<int>(first);
      if (absl::Status s = file.Write(Product::kBoundsLower, frame, first_plane, buffers.block);
          !s.ok()) {
        return s;
      }
      if (absl::Status s =
              file.Write(Product::kBoundsUpper, frame, first_plane, buffers.second_block);
          !s.ok()) {
        return s;
      }
    }
  }
  return absl::OkStatus();
}

// Refuses to replace the input with the output: the rename at the end would destroy it.
absl::Status CheckOutputIsNotInput(const ReconstructArgs& args) {
  std::error_code error;
  if (std::filesystem::equivalent(args.input_path, args.output_path, error)) {
    return absl::InvalidArgumentError(absl::StrCat(args.output_path, ": is the input file ",
                                                   args.input_path, "; refusing to overwrite it"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::string_view BiasModeName(BiasMode mode) {
  return mode == BiasMode::kRaiseZeroth ? "raise" : "scale";
}

absl::string_view ZerothName(ZerothMoment zeroth) {
  return zeroth == ZerothMoment::kMeasured ? "measured" : "estimate";
}

absl::StatusOr<Method> ParseMethod(absl::string_view text) {
  for (Method method : {Method::kMese, Method::kPisarenko, Method::kBoth}) {
    if (text == MethodName(method)) return method;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("--method = '", text, "': expected mese, pisarenko or both"));
}

absl::StatusOr<BiasMode> ParseBiasMode(absl::string_view text) {
  for (BiasMode mode : {BiasMode::kRaiseZeroth, BiasMode::kScaleMoments}) {
    if (text == BiasModeName(mode)) return mode;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("--bias-mode = '", text, "': expected raise or scale"));
}

absl::StatusOr<ZerothMoment> ParseZeroth(absl::string_view text) {
  for (ZerothMoment zeroth : {ZerothMoment::kMeasured, ZerothMoment::kEstimate}) {
    if (text == ZerothName(zeroth)) return zeroth;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("--zeroth = '", text, "': expected measured or estimate"));
}

absl::Status ReconstructArgs::Validate() const {
  if (input_path.empty()) return absl::InvalidArgumentError("input file: the path is empty");
  if (output_path.empty()) return absl::InvalidArgumentError("output file: the path is empty");
  if (bins < kMinBins || bins > kMaxBins) {
    return absl::InvalidArgumentError(
        absl::StrCat("--bins = ", bins, ": expected an integer in ", kMinBins, "..", kMaxBins));
  }
  // Written so that NaN fails every check.
  if (!(bias_epsilon >= transient::kMinBiasEpsilon && bias_epsilon < 1.0)) {
    return absl::InvalidArgumentError(absl::StrCat("--bias-epsilon = ", bias_epsilon, ": expected ",
                                                   transient::kMinBiasEpsilon, " <= E < 1"));
  }
  if (!(threshold >= 0.0 && threshold < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--threshold = ", threshold, ": expected 0 <= T < 1"));
  }
  if (bounds_r.has_value() && !(*bounds_r > 0.0 && *bounds_r < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--bounds-r = ", *bounds_r, ": expected 0 < R < 1"));
  }
  return absl::OkStatus();
}

std::string FormatSummary(const ReconstructSummary& summary) {
  const auto percent = [&](int64_t count) {
    return summary.pixels > 0 ? 100.0 * static_cast<double>(count) / summary.pixels : 0.0;
  };
  return absl::StrFormat(
      "%d frame%s of %dx%d px (%d pixels), m=%d, %s: %.1f%% biased, %.1f%% invalid, %.1f%% no "
      "return, %.2f s -> %s",
      summary.frames, summary.frames == 1 ? "" : "s", summary.geometry.width,
      summary.geometry.height, summary.pixels, summary.order, MethodName(summary.method),
      percent(summary.biased), percent(summary.invalid), percent(summary.no_return),
      summary.seconds, summary.output_path);
}

namespace {

// Memory one frame needs while it is reconstructed: the float32 moment planes, the solver's
// double planes of c and q, Pisarenko's planes, a few single planes and one block of bins.
uint64_t FrameWorkingBytes(int order, uint64_t pixels, uint64_t block_values) {
  const uint64_t size = static_cast<uint64_t>(order) + 1;
  return pixels * (size * 2 * sizeof(float) + size * 4 * sizeof(double) +
                   (2 * size + 1) * sizeof(float) + 4 * sizeof(float) + 3) +
         2 * block_values * sizeof(float);
}

uint64_t PhysicalMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page_size = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && page_size > 0 ? static_cast<uint64_t>(pages) * page_size : 0;
}

absl::StatusOr<ReconstructSummary> ReconstructFile(const ReconstructArgs& given_args,
                                                   const CommandHooks& hooks) {
  const auto start_time = std::chrono::steady_clock::now();
  if (absl::Status status = given_args.Validate(); !status.ok()) return status;

  absl::StatusOr<MomentFile> input = MomentFile::Open(given_args.input_path);
  if (!input.ok()) return input.status();
  ReconstructArgs args = given_args;
  if (args.zeroth_from_file && input->zeroth_hint().has_value()) args.zeroth = *input->zeroth_hint();
  absl::StatusOr<FrameRange> frames = ResolveFrameSlice(args.frames, input->frames());
  if (!frames.ok()) return WithContext(args.input_path, frames.status());

  const std::vector<double> phases = UniformPhases(args.bins);
  FrameReconstructor reconstructor(args, input->base_frequency_hz(), phases);
  if (absl::Status status = reconstructor.ValidateOptions(); !status.ok()) {
    return WithContext(args.input_path, status);
  }
  if (absl::Status status = CheckOutputIsNotInput(args); !status.ok()) return status;
  const uint64_t pixels = static_cast<uint64_t>(input->geometry().pixel_count());
  const uint64_t block_values =
      std::max<uint64_t>(pixels, std::min<uint64_t>(args.max_block_values, pixels * args.bins));
  const uint64_t needed = FrameWorkingBytes(input->order(), pixels, block_values);
  if (const uint64_t available = PhysicalMemoryBytes(); available > 0 && needed > available) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "%s: a %dx%d frame with m = %d needs about %.1f GiB of memory to reconstruct; this "
        "machine has %.1f GiB",
        args.input_path, input->geometry().width, input->geometry().height, input->order(),
        needed / 1073741824.0, available / 1073741824.0));
  }
  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(args.output_path);
  if (!output.ok()) return output.status();

  ReconstructionHeader header{
      .frames = frames->count,
      .order = input->order(),
      .geometry = input->geometry(),
      .phases = phases,
      .mese = HasMese(args.method),
      .pisarenko = HasPisarenko(args.method),
      .bounds_r = args.bounds_r,
      .base_frequency_hz = input->base_frequency_hz(),
      .method = std::string(MethodName(args.method)),
      .bias_epsilon = args.bias_epsilon,
      .bias_mode = std::string(BiasModeName(args.bias_mode)),
      .zeroth = std::string(ZerothName(args.zeroth)),
      .threshold = args.threshold,
      .first_frame = frames->first,
      .source = args.input_path,
  };
  absl::StatusOr<ReconstructionFile> file =
      ReconstructionFile::Create(output->temporary_path(), header);
  if (!file.ok()) return file.status();

  ReconstructSummary summary{.output_path = args.output_path,
                             .frames = frames->count,
                             .geometry = input->geometry(),
                             .order = input->order(),
                             .method = args.method};
  FrameBuffers buffers;
  FrameCounts counts;
  for (int64_t k = 0; k < frames->count; ++k) {
    if (hooks.cancelled()) {
      return absl::CancelledError("interrupted; no output written");
    }
    if (absl::Status status = input->ReadFrame(frames->first + k, &buffers.moments); !status.ok()) {
      return status;
    }
    if (absl::Status status = buffers.moments.Validate(); !status.ok()) {
      return absl::InternalError(
          absl::StrCat(args.input_path, ": frame ", frames->first + k, ": ", status.message()));
    }
    if (absl::Status status = reconstructor.Run(buffers.moments, k, *file, buffers, counts);
        !status.ok()) {
      return status;
    }
    hooks.Progress(k + 1, frames->count);
  }
  // An interrupt during the last frame still means "stop": nothing is committed.
  if (hooks.cancelled()) {
    return absl::CancelledError("interrupted; no output written");
  }
  if (absl::Status status = file->Close(); !status.ok()) return status;
  if (absl::Status status = output->Commit(); !status.ok()) return status;

  summary.pixels = frames->count * input->geometry().pixel_count();
  summary.biased = counts.biased;
  summary.invalid = counts.invalid;
  summary.no_return = counts.no_return;
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return summary;
}

}  // namespace

absl::StatusOr<ReconstructSummary> RunReconstruct(const ReconstructArgs& args,
                                                  const CommandHooks& hooks) {
  absl::StatusOr<ReconstructSummary> result;
  // Exceptions (an allocation that fails, a library that throws) unwind through
  // ReconstructFile, so its AtomicOutput removes the partial file; they become statuses.
  try {
    result = ReconstructFile(args, hooks);
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError(
        absl::StrCat(args.input_path, ": out of memory while reconstructing; no output written"));
  } catch (const std::exception& e) {
    return absl::InternalError(
        absl::StrCat(args.input_path, ": ", e.what(), "; no output written"));
  }
  if (result.ok()) return result;
  // Messages about the output name the file the user asked for, not its temporary name.
  return WithFinalPath(result.status(), args.output_path);
}

}  // namespace transient::tools
