// The daemon's config file (--config): any bytes through ParseConfig. Property: a config the
// parser accepts is valid.
#include <cstdint>
#include <cstdlib>

#include "transient/service/reconstruction_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  transient::service::ReconstructionConfig config;
  const absl::string_view text(reinterpret_cast<const char*>(data), size);
  if (transient::service::ParseConfig(text, "fuzz.conf", &config).ok() && !config.Validate().ok()) {
    std::abort();
  }
  return 0;
}
