// Progress bar on a terminal.
#include "tools/transient/common/progress_bar.h"

#include <unistd.h>

#include <string>

namespace transient::tools {
namespace {

constexpr int kBarWidth = 40;

}  // namespace

ProgressBar::ProgressBar(std::FILE* stream, int64_t total)
    : stream_(::isatty(::fileno(stream)) != 0 ? stream : nullptr), total_(total) {}

ProgressBar::~ProgressBar() {
  if (stream_ == nullptr) return;
  std::fputs("\r\033[K", stream_);  // back to column 0, clear the line
  std::fflush(stream_);
}

void ProgressBar::Update(int64_t done) {
  if (stream_ == nullptr || total_ <= 0) return;
  const int filled = static_cast<int>(kBarWidth * done / total_);
  const std::string bar = std::string(filled, '#') + std::string(kBarWidth - filled, '.');
  std::fprintf(stream_, "\r[%s] %lld/%lld frames", bar.c_str(), static_cast<long long>(done),
               static_cast<long long>(total_));
  std::fflush(stream_);
}

}  // namespace transient::tools
