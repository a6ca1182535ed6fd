// Reconstruction settings: checks, description and the config file.
#include "transient/service/reconstruction_config.h"

#include <fstream>
#include <sstream>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "transient/reconstruct/reconstructor.h"
#include "transient/reconstruct/smoothing.h"

namespace transient::service {

absl::Status ReconstructionConfig::Validate() const {
  const SolveOptions solve{.bias_epsilon = bias_epsilon};
  if (absl::Status status = solve.Validate(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("bias_epsilon: ", status.message()));
  }
  if (!(threshold > 0.0 && threshold < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("threshold = ", threshold, ": expected 0 < threshold < 1"));
  }
  if (absl::Status status = ValidateSmoothingSigma(smoothing_sigma_px); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("smoothing_sigma_px: ", status.message()));
  }
  if (takes < 1 || takes > kMaxTakes) {
    return absl::InvalidArgumentError(
        absl::StrCat("takes = ", takes, ": expected 1..", kMaxTakes));
  }
  return absl::OkStatus();
}

std::string DescribeConfig(const ReconstructionConfig& config) {
  return absl::StrFormat(
      "range %s, bias_epsilon %g, threshold %g, smoothing %g px, %d takes, video %s",
      config.range_method == RangeMethod::kMese ? "mese" : "pisarenko", config.bias_epsilon,
      config.threshold, config.smoothing_sigma_px, config.takes, config.video ? "on" : "off");
}

bool IsDaemonKey(absl::string_view key) {
  static constexpr absl::string_view kKeys[] = {
      "publish",      "nats_camera",    "nats_products", "nats_encoding",  "nats_zstd",
      "nats_max_age", "nats_max_bytes", "nats_replicas", "nats_user_file", "nats_creds",
      "nats_ca",      "nats_cert",      "nats_key"};
  for (absl::string_view k : kKeys) {
    if (key == k) return true;
  }
  return false;
}

absl::Status ReadConfigFile(const std::string& path, ReconstructionConfig* config,
                            DaemonKeys* daemon) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot be read"));
  std::ostringstream content;
  content << in.rdbuf();
  return ParseConfig(content.str(), path, config, daemon);
}

absl::Status ParseConfig(absl::string_view content, absl::string_view path,
                         ReconstructionConfig* config, DaemonKeys* daemon) {
  int number = 0;
  for (absl::string_view line : absl::StrSplit(content, '\n')) {
    ++number;
    absl::string_view text = line;
    if (size_t hash = text.find('#'); hash != absl::string_view::npos) text = text.substr(0, hash);
    text = absl::StripAsciiWhitespace(text);
    if (text.empty()) continue;
    std::vector<std::string> parts = absl::StrSplit(text, absl::MaxSplits('=', 1));
    auto where = [&] { return absl::StrCat(path, ":", number, ": "); };
    if (parts.size() != 2) {
      return absl::InvalidArgumentError(absl::StrCat(where(), "expected key = value"));
    }
    const std::string key(absl::StripAsciiWhitespace(parts[0]));
    const std::string value(absl::StripAsciiWhitespace(parts[1]));
    auto number_of = [&](double* out) -> absl::Status {
      if (!absl::SimpleAtod(value, out)) {
        return absl::InvalidArgumentError(absl::StrCat(where(), key, " = ", value,
                                                       ": expected a number"));
      }
      return absl::OkStatus();
    };
    absl::Status status;
    if (daemon != nullptr && IsDaemonKey(key)) {
      daemon->emplace_back(key, value);
      continue;
    }
    if (key == "range_method") {
      if (value == "mese") {
        config->range_method = RangeMethod::kMese;
      } else if (value == "pisarenko") {
        config->range_method = RangeMethod::kPisarenko;
      } else {
        status = absl::InvalidArgumentError(
            absl::StrCat(where(), "range_method = ", value, ": expected mese or pisarenko"));
      }
    } else if (key == "bias_epsilon") {
      status = number_of(&config->bias_epsilon);
    } else if (key == "threshold") {
      status = number_of(&config->threshold);
    } else if (key == "smoothing_sigma_px") {
      status = number_of(&config->smoothing_sigma_px);
    } else if (key == "takes") {
      if (!absl::SimpleAtoi(value, &config->takes)) {
        status = absl::InvalidArgumentError(
            absl::StrCat(where(), "takes = ", value, ": expected an integer"));
      }
    } else if (key == "video") {
      if (!absl::SimpleAtob(value, &config->video)) {
        status = absl::InvalidArgumentError(
            absl::StrCat(where(), "video = ", value, ": expected true or false"));
      }
    } else {
      status = absl::InvalidArgumentError(absl::StrCat(
          where(), "unknown key '", key,
          "'; expected range_method, bias_epsilon, threshold, smoothing_sigma_px, takes, video",
          daemon != nullptr ? ", publish or nats_* (docs/nats.md)" : ""));
    }
    if (!status.ok()) return status;
  }
  if (absl::Status status = config->Validate(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", status.message()));
  }
  return absl::OkStatus();
}

}  // namespace transient::service
