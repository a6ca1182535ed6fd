// A one-line progress bar redrawn in place on a terminal ("[#####.....] 12/40 frames").
#pragma once

#include <cstdint>
#include <cstdio>

namespace transient::tools {

class ProgressBar {
 public:
  // Draws on `stream` only if it is a terminal, so that logs and pipes stay clean.
  ProgressBar(std::FILE* stream, int64_t total);
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  // Erases the bar so that the next output starts on a clean line.
  ~ProgressBar();

  void Update(int64_t done);

 private:
  std::FILE* stream_;  // nullptr: not a terminal, draw nothing
  int64_t total_;
};

}  // namespace transient::tools
