// The data directory: every kind of name a client may send, and the quota's arithmetic.
#include "transient/service/data_dir.h"

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"

namespace transient::service {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::IsOkAndHolds;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

TEST(DataDir, OpenCreatesTheDirectoryAndRefusesAFile) {
  ScratchDirectory scratch;
  absl::StatusOr<DataDir> made = DataDir::Open(scratch.File("a/b"), {});
  ASSERT_THAT(made.status(), IsOk());
  EXPECT_TRUE(std::filesystem::is_directory(scratch.File("a/b")));
  EXPECT_EQ(made->root(), std::filesystem::canonical(scratch.File("a/b")).string());
  std::ofstream(scratch.File("file")) << "x";
  EXPECT_THAT(DataDir::Open(scratch.File("file"), {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("not a directory")));
  std::filesystem::create_directory(scratch.File("shared"));
  std::filesystem::permissions(scratch.File("shared"), std::filesystem::perms::others_write,
                               std::filesystem::perm_options::add);
  EXPECT_THAT(DataDir::Open(scratch.File("shared"), {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("writable by every user")));
  EXPECT_THAT(DataDir::Open("", {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("expected a path")));
}

TEST(DataDir, NewNamesResolveInsideTheDirectory) {
  ScratchDirectory scratch;
  absl::StatusOr<DataDir> data = DataDir::Open(scratch.path().string(), {});
  ASSERT_THAT(data.status(), IsOk());
  EXPECT_THAT(data->NewFilePath("path", "capture.h5"), IsOkAndHolds(data->root() + "/capture.h5"));
  std::filesystem::create_directory(scratch.File("day1"));
  EXPECT_THAT(data->NewFilePath("path", "day1/capture.h5"),
              IsOkAndHolds(data->root() + "/day1/capture.h5"));
  // Names with dots that are not "." or "..".
  EXPECT_THAT(data->NewFilePath("path", "..capture.h5").status(), IsOk());
  EXPECT_THAT(data->NewFilePath("path", "a...h5").status(), IsOk());
}

// Each kind of name that could reach outside the directory, or replace or open something that
// is there, is refused with the field and the reason.
TEST(DataDir, EveryKindOfNameOutsideOrInTheWayIsRefused) {
  ScratchDirectory outside;
  ScratchDirectory scratch;
  absl::StatusOr<DataDir> data = DataDir::Open(scratch.path().string(), {});
  ASSERT_THAT(data.status(), IsOk());
  std::ofstream(scratch.File("taken.h5")) << "x";
  std::filesystem::create_directory(scratch.File("dir"));
  std::filesystem::create_directory_symlink(outside.path(), scratch.File("out"));
  std::filesystem::create_symlink(outside.File("target.h5"), scratch.File("dangling.h5"));
  std::filesystem::create_symlink(scratch.File("taken.h5"), scratch.File("inside-link.h5"));
  ASSERT_EQ(::mkfifo(scratch.File("fifo").c_str(), 0600), 0);
  const int sock = ::socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(sock, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  const std::string socket_path = scratch.File("sock");
  ASSERT_LT(socket_path.size(), sizeof(address.sun_path));
  socket_path.copy(address.sun_path, socket_path.size());
  ASSERT_EQ(::bind(sock, reinterpret_cast<const sockaddr*>(&address), sizeof(address)), 0);

  struct Case {
    std::string name;
    absl::StatusCode code;
    std::string why;
  };
  const std::vector<Case> cases = {
      {"", absl::StatusCode::kInvalidArgument, "expected a new file's name"},
      {"/tmp/x.h5", absl::StatusCode::kInvalidArgument, "an absolute path"},
      {outside.File("x.h5"), absl::StatusCode::kInvalidArgument, "an absolute path"},
      {"../x.h5", absl::StatusCode::kInvalidArgument, "a component \"..\""},
      {"dir/../../x.h5", absl::StatusCode::kInvalidArgument, "a component \"..\""},
      {"./x.h5", absl::StatusCode::kInvalidArgument, "a component \".\""},
      {"dir//x.h5", absl::StatusCode::kInvalidArgument, "an empty component"},
      {"dir/", absl::StatusCode::kInvalidArgument, "an empty component"},
      {"x\n.h5", absl::StatusCode::kInvalidArgument, "a control character"},
      {std::string("x\0.h5", 5), absl::StatusCode::kInvalidArgument, "a control character"},
      {std::string(256, 'a'), absl::StatusCode::kInvalidArgument, "longer than 255 bytes"},
      {std::string(1025, 'a'), absl::StatusCode::kInvalidArgument, "1025 bytes long"},
      {"out/x.h5", absl::StatusCode::kInvalidArgument, "a symbolic link on the way"},
      {"dangling.h5", absl::StatusCode::kInvalidArgument, "a symbolic link"},
      {"inside-link.h5", absl::StatusCode::kInvalidArgument, "a symbolic link"},
      {"taken.h5/x.h5", absl::StatusCode::kInvalidArgument, "not a directory"},
      {"dir", absl::StatusCode::kInvalidArgument, "a directory"},
      {"fifo", absl::StatusCode::kInvalidArgument, "a FIFO"},
      {"sock", absl::StatusCode::kInvalidArgument, "a socket"},
      {"taken.h5", absl::StatusCode::kAlreadyExists, "nothing is ever replaced"},
      {"missing/x.h5", absl::StatusCode::kNotFound, "no directory \"missing\""},
      {"dir/missing/x.h5", absl::StatusCode::kNotFound, "no directory \"dir/missing\""},
  };
  for (const Case& c : cases) {
    EXPECT_THAT(data->NewFilePath("path", c.name).status(),
                StatusIs(c.code, AllOf(HasSubstr("path"), HasSubstr(c.why))))
        << "name: " << c.name;
  }
  ::close(sock);
  // Nothing was created outside, and the link's target still does not exist.
  EXPECT_TRUE(outside.Entries().empty());
}

TEST(DataDir, ExistingNamesMustBeRegularFilesInside) {
  ScratchDirectory outside;
  ScratchDirectory scratch;
  absl::StatusOr<DataDir> data = DataDir::Open(scratch.path().string(), {});
  ASSERT_THAT(data.status(), IsOk());
  std::filesystem::create_directory(scratch.File("day1"));
  std::ofstream(scratch.File("day1/capture.h5")) << "x";
  std::ofstream(outside.File("capture.h5")) << "x";
  std::filesystem::create_symlink(outside.File("capture.h5"), scratch.File("link.h5"));
  EXPECT_THAT(data->ExistingFilePath("source_uri", "day1/capture.h5"),
              IsOkAndHolds(data->root() + "/day1/capture.h5"));
  EXPECT_THAT(data->ExistingFilePath("source_uri", "missing.h5").status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("no file \"missing.h5\"")));
  EXPECT_THAT(data->ExistingFilePath("source_uri", "link.h5").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("a symbolic link")));
  EXPECT_THAT(data->ExistingFilePath("source_uri", outside.File("capture.h5")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("an absolute path")));
  EXPECT_THAT(data->ExistingFilePath("source_uri", "day1").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("a directory")));
}

TEST(DataDir, UsageCountsRegularFilesWithoutFollowingLinks) {
  ScratchDirectory outside;
  ScratchDirectory scratch;
  absl::StatusOr<DataDir> data = DataDir::Open(scratch.path().string(), {});
  ASSERT_THAT(data.status(), IsOk());
  EXPECT_EQ(data->Usage().files, 0u);
  std::ofstream(scratch.File("a")) << std::string(1000, 'a');
  std::filesystem::create_directory(scratch.File("d"));
  std::ofstream(scratch.File("d/b")) << std::string(24, 'b');
  std::ofstream(outside.File("big")) << std::string(5000, 'c');
  std::filesystem::create_directory_symlink(outside.path(), scratch.File("out"));
  std::filesystem::create_symlink(outside.File("big"), scratch.File("big-link"));
  const DataUsage usage = data->Usage();
  EXPECT_EQ(usage.files, 2u);
  EXPECT_EQ(usage.bytes, 1024u);
}

TEST(DataDir, CheckRoomSaysWhichLimitIsReached) {
  ScratchDirectory scratch;
  std::ofstream(scratch.File("a")) << std::string(1000, 'a');
  absl::StatusOr<DataDir> unlimited = DataDir::Open(scratch.path().string(), {});
  ASSERT_THAT(unlimited.status(), IsOk());
  EXPECT_THAT(unlimited->CheckRoom(uint64_t{1} << 60), IsOk());
  EXPECT_EQ(unlimited->BytesLeft(), std::numeric_limits<uint64_t>::max());

  absl::StatusOr<DataDir> bytes = DataDir::Open(scratch.path().string(), {.max_bytes = 1500});
  ASSERT_THAT(bytes.status(), IsOk());
  EXPECT_EQ(bytes->BytesLeft(), 500u);
  EXPECT_THAT(bytes->CheckRoom(500), IsOk());
  EXPECT_THAT(bytes->CheckRoom(501),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       AllOf(HasSubstr("1000 bytes of its quota of 1500"), HasSubstr("501"))));

  absl::StatusOr<DataDir> files = DataDir::Open(scratch.path().string(), {.max_files = 1});
  ASSERT_THAT(files.status(), IsOk());
  EXPECT_THAT(files->CheckRoom(0), StatusIs(absl::StatusCode::kResourceExhausted,
                                            HasSubstr("holds 1 files, its quota is 1")));
}

}  // namespace
}  // namespace transient::service
