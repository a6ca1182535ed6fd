// ffprobe -count_frames on the first video stream, parsed from its key=value output.
#include "tests/support/video_probe.h"

#include <filesystem>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "tests/support/subprocess.h"

namespace transient::testing {

absl::StatusOr<VideoInfo> ProbeVideo(const std::string& path) {
  if (!std::filesystem::exists(path)) return absl::NotFoundError(absl::StrCat(path, ": no file"));
  const ProcessResult probe = RunProcess(
      {"ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
       "stream=codec_name,width,height,nb_read_frames", "-of", "default=noprint_wrappers=1",
       path});
  if (probe.exit_code != 0) {
    return absl::DataLossError(absl::StrCat(path, ": ffprobe exit ", probe.exit_code, ": ",
                                            probe.err));
  }
  VideoInfo info;
  bool counted = false;
  for (absl::string_view line : absl::StrSplit(probe.out, '\n', absl::SkipEmpty())) {
    const std::vector<absl::string_view> pair = absl::StrSplit(line, absl::MaxSplits('=', 1));
    if (pair.size() != 2) continue;
    if (pair[0] == "codec_name") info.codec = std::string(pair[1]);
    if (pair[0] == "width") (void)absl::SimpleAtoi(pair[1], &info.width);
    if (pair[0] == "height") (void)absl::SimpleAtoi(pair[1], &info.height);
    if (pair[0] == "nb_read_frames") counted = absl::SimpleAtoi(pair[1], &info.frames);
  }
  if (!counted) {
    return absl::DataLossError(absl::StrCat(path, ": no video stream (ffprobe: ", probe.out, ")"));
  }
  return info;
}

}  // namespace transient::testing
