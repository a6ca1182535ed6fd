// The reconstruction parameters that SetConfig and the daemon's config file may change while
// frames flow, their checks, and the config file's `key = value` syntax.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "transient/service/products.h"

namespace transient::service {

inline constexpr int kMaxTakes = 64;

struct ReconstructionConfig {
  RangeMethod range_method = RangeMethod::kMese;
  double bias_epsilon = 4e-3;        // thesis §8.5
  double threshold = 0.1;            // relative, (0, 1)
  double smoothing_sigma_px = 0.6;   // thesis §8.5; 0 = none
  int takes = 1;                     // cycles of the schedule averaged per frame (sim sources)
  bool video = true;                 // fill outlier captures from the previous frame

  // InvalidArgument naming the field, its value and the rule.
  absl::Status Validate() const;
};

// "range mese, bias_epsilon 0.004, threshold 0.1, smoothing 0.6 px, 1 takes, video on".
std::string DescribeConfig(const ReconstructionConfig& config);

// Reads `key = value` lines into `config` ('#' starts a comment; keys range_method (mese |
// pisarenko), bias_epsilon, threshold, smoothing_sigma_px, takes, video (true | false)); keys
// not in the file keep their values. NotFound when the file cannot be read; InvalidArgument
// "<path>:<line>: ..." naming the key, the value and the rule, or "<path>: ..." when the
// result fails Validate().
// `daemon`: when given, the daemon's own keys are taken too and stored there as they are
// written (`publish` and the `nats_*` keys of `transientd --publish`, docs/nats.md); without
// it they are unknown keys.
using DaemonKeys = std::vector<std::pair<std::string, std::string>>;
absl::Status ReadConfigFile(const std::string& path, ReconstructionConfig* config,
                            DaemonKeys* daemon = nullptr);
// The same from the file's `content`, named `path` in messages.
absl::Status ParseConfig(absl::string_view content, absl::string_view path,
                         ReconstructionConfig* config, DaemonKeys* daemon = nullptr);

// The daemon's keys of a config file: publish, nats_camera, nats_products, nats_encoding,
// nats_zstd, nats_max_age, nats_max_bytes, nats_replicas, nats_user_file, nats_creds, nats_ca,
// nats_cert, nats_key.
bool IsDaemonKey(absl::string_view key);

}  // namespace transient::service
