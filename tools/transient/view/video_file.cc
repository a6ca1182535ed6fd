// ffmpeg behind a Status interface: raw RGB frames go to its standard input, H.264 MP4 comes out.
#include "tools/transient/view/video_file.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

extern char** environ;

namespace transient::tools {
namespace {

// The last bytes of ffmpeg's log quoted in an error: its final lines say what went wrong.
constexpr std::streamoff kLogTailBytes = 600;

void CloseFd(int* fd) {
  if (*fd >= 0) ::close(*fd);
  *fd = -1;
}

}  // namespace

absl::StatusOr<Mp4Writer> Mp4Writer::Open(const std::string& path, double fps, cv::Size size) {
  if (!absl::EndsWith(path, ".mp4")) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": expected a name ending in .mp4"));
  }
  if (!(fps > 0.0 && fps <= 240.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", fps, " frames per second: expected 0 < fps <= 240"));
  }
  if (size.width <= 0 || size.height <= 0 || size.width % 2 != 0 || size.height % 2 != 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": frames of ", size.width, "x",
                                                   size.height,
                                                   " px: expected even, positive sizes"));
  }
  const std::filesystem::path final_path(path);
  const std::filesystem::path directory =
      final_path.has_parent_path() ? final_path.parent_path() : std::filesystem::path(".");
  std::error_code error;
  if (!std::filesystem::is_directory(directory, error)) {
    return absl::NotFoundError(
        absl::StrCat(path, ": directory ", directory.string(), " does not exist"));
  }
  if (::access(directory.c_str(), W_OK) != 0) {
    return absl::PermissionDeniedError(
        absl::StrCat(path, ": directory ", directory.string(), " is not writable"));
  }
  Mp4Writer writer;
  writer.path_ = path;
  // ffmpeg picks the container from the extension, so the temporary name keeps ".mp4".
  const std::string stem = absl::StrCat(".", final_path.stem().string(), ".tmp-", ::getpid());
  writer.temporary_path_ = (directory / absl::StrCat(stem, ".mp4")).string();
  writer.log_path_ = (directory / absl::StrCat(stem, ".log")).string();
  writer.size_ = size;
  writer.armed_ = true;

  int sockets[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sockets) != 0) {
    return absl::UnavailableError(
        absl::StrCat(path, ": cannot create ffmpeg's input: ", std::strerror(errno)));
  }
  int encoder_input = sockets[1];
  writer.input_ = sockets[0];
  const int log = ::open(writer.log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (log < 0) {
    CloseFd(&encoder_input);
    return absl::PermissionDeniedError(
        absl::StrCat(path, ": cannot create ", writer.log_path_, ": ", std::strerror(errno)));
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, encoder_input, STDIN_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, log, STDERR_FILENO);
  const std::string frame_size = absl::StrCat(size.width, "x", size.height);
  const std::string rate = absl::StrFormat("%.6g", fps);
  // rgb24 in, yuv420p H.264 out (what players expect), the index at the front of the file.
  std::vector<std::string> arguments = {
      "ffmpeg", "-nostdin", "-hide_banner", "-loglevel", "error", "-f", "rawvideo",
      "-pix_fmt", "rgb24", "-s", frame_size, "-r", rate, "-i", "pipe:0", "-c:v", "libx264",
      "-pix_fmt", "yuv420p", "-movflags", "+faststart", "-y", writer.temporary_path_};
  std::vector<char*> argv;
  for (std::string& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int spawned = ::posix_spawnp(&pid, "ffmpeg", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(log);
  CloseFd(&encoder_input);
  if (spawned != 0) {
    return absl::UnavailableError(absl::StrCat(path, ": cannot start ffmpeg (",
                                               std::strerror(spawned),
                                               "); it encodes the video: apt install ffmpeg"));
  }
  writer.encoder_ = pid;
  return writer;
}

Mp4Writer::Mp4Writer(Mp4Writer&& other) noexcept
    : path_(std::move(other.path_)),
      temporary_path_(std::move(other.temporary_path_)),
      log_path_(std::move(other.log_path_)),
      size_(other.size_),
      input_(std::exchange(other.input_, -1)),
      encoder_(std::exchange(other.encoder_, -1)),
      frames_(other.frames_),
      armed_(std::exchange(other.armed_, false)) {}

Mp4Writer::~Mp4Writer() {
  CloseFd(&input_);  // ffmpeg sees the end of its input and exits
  if (encoder_ > 0) {
    if (armed_) ::kill(encoder_, SIGTERM);  // a failed run: no need to finish the file
    int status = 0;
    while (::waitpid(encoder_, &status, 0) < 0 && errno == EINTR) {
    }
    encoder_ = -1;
  }
  std::error_code ignored;
  if (!log_path_.empty()) std::filesystem::remove(log_path_, ignored);
  if (armed_) std::filesystem::remove(temporary_path_, ignored);
}

std::string Mp4Writer::LogTail() const {
  std::ifstream log(log_path_, std::ios::binary);
  log.seekg(0, std::ios::end);
  const std::streamoff size = log.tellg();
  log.seekg(size > kLogTailBytes ? size - kLogTailBytes : 0);
  std::stringstream text;
  text << log.rdbuf();
  std::string tail = text.str();
  while (!tail.empty() && (tail.back() == '\n' || tail.back() == '\r')) tail.pop_back();
  for (char& c : tail) c = c == '\n' ? ';' : c;
  return tail.empty() ? "no message" : tail;
}

absl::Status Mp4Writer::Finish() {
  CloseFd(&input_);
  if (encoder_ <= 0) return absl::FailedPreconditionError(absl::StrCat(path_, ": closed"));
  int status = 0;
  pid_t waited;
  while ((waited = ::waitpid(encoder_, &status, 0)) < 0 && errno == EINTR) {
  }
  encoder_ = -1;
  if (waited < 0) {
    return absl::UnavailableError(absl::StrCat(path_, ": lost ffmpeg: ", std::strerror(errno)));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    return absl::UnavailableError(absl::StrCat(
        path_, ": ffmpeg failed (",
        WIFEXITED(status) ? absl::StrCat("exit status ", WEXITSTATUS(status))
                          : absl::StrCat("signal ", WTERMSIG(status)),
        "): ", LogTail()));
  }
  return absl::OkStatus();
}

absl::Status Mp4Writer::Write(const cv::Mat& rgb) {
  if (rgb.type() != CV_8UC3 || rgb.size() != size_) {
    return absl::InternalError(absl::StrCat(path_, ": frame of ", rgb.cols, "x", rgb.rows,
                                            " px for a video of ", size_.width, "x",
                                            size_.height));
  }
  if (input_ < 0) return absl::FailedPreconditionError(absl::StrCat(path_, ": closed"));
  const size_t row_bytes = static_cast<size_t>(size_.width) * 3;
  for (int y = 0; y < rgb.rows; ++y) {
    const char* row = reinterpret_cast<const char*>(rgb.ptr(y));
    for (size_t sent = 0; sent < row_bytes;) {
      const ssize_t n = ::send(input_, row + sent, row_bytes - sent, MSG_NOSIGNAL);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        absl::Status finished = Finish();
        return absl::UnavailableError(absl::StrCat(
            path_, ": writing frame ", frames_, ": ffmpeg stopped reading",
            finished.ok() ? "" : absl::StrCat(" (", finished.message(), ")")));
      }
      sent += static_cast<size_t>(n);
    }
  }
  ++frames_;
  return absl::OkStatus();
}

absl::Status Mp4Writer::Close() {
  if (absl::Status status = Finish(); !status.ok()) return status;
  std::error_code error;
  if (std::filesystem::file_size(temporary_path_, error) == 0 || error) {
    return absl::UnavailableError(absl::StrCat(path_, ": ffmpeg wrote no video"));
  }
  std::filesystem::rename(temporary_path_, path_, error);
  if (error) {
    return absl::PermissionDeniedError(absl::StrCat(
        path_, ": cannot rename ", temporary_path_, " into place (", error.message(), ")"));
  }
  armed_ = false;
  return absl::OkStatus();
}

}  // namespace transient::tools
