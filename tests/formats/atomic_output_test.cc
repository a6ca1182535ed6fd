// AtomicOutput: an output appears at its final path whole or not at all, a failed or abandoned
// write leaves neither the file nor its temporary, and kNeverReplace never replaces a file.
#include "transient/formats/atomic_output.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/unprivileged.h"

namespace transient {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::StartsWith;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(AtomicOutput, CommitPutsTheFileInPlaceAndLeavesNoTemporary) {
  for (CommitMode mode : {CommitMode::kReplace, CommitMode::kNeverReplace}) {
    ScratchDirectory scratch;
    const std::string path = scratch.File("out.h5");
    absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path, mode);
    ASSERT_THAT(output.status(), IsOk());
    EXPECT_EQ(output->final_path(), path);
    EXPECT_EQ(output->mode(), mode);
    EXPECT_THAT(scratch.Entries(), IsEmpty());  // Prepare creates nothing
    WriteText(output->temporary_path(), "new");
    EXPECT_FALSE(std::filesystem::exists(path));  // not before Commit
    ASSERT_THAT(output->Commit(), IsOk());
    EXPECT_EQ(ReadText(path), "new");
    EXPECT_THAT(scratch.Entries(), ElementsAre("out.h5"));
  }
}

TEST(AtomicOutput, ReplaceModeReplacesAnExistingFileWhole) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("out.h5");
  WriteText(path, "old contents, longer than the new ones");
  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path, CommitMode::kReplace);
  ASSERT_THAT(output.status(), IsOk());
  WriteText(output->temporary_path(), "new");
  EXPECT_EQ(ReadText(path), "old contents, longer than the new ones");  // untouched until Commit
  ASSERT_THAT(output->Commit(), IsOk());
  EXPECT_EQ(ReadText(path), "new");
  EXPECT_THAT(scratch.Entries(), ElementsAre("out.h5"));
}

TEST(AtomicOutput, NeverReplaceRefusesAnExistingFileAtPrepare) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("taken.h5");
  WriteText(path, "someone's data");
  EXPECT_THAT(AtomicOutput::Prepare(path, CommitMode::kNeverReplace).status(),
              StatusIs(absl::StatusCode::kAlreadyExists,
                       HasSubstr("taken.h5: exists; this output never replaces a file")));
  // A dangling symbolic link is a name that exists too.
  std::filesystem::create_symlink(scratch.File("nowhere"), scratch.File("link.h5"));
  EXPECT_THAT(AtomicOutput::Prepare(scratch.File("link.h5"), CommitMode::kNeverReplace).status(),
              StatusIs(absl::StatusCode::kAlreadyExists, ::testing::_));
  EXPECT_EQ(ReadText(path), "someone's data");
  EXPECT_THAT(scratch.Entries(), ElementsAre("link.h5", "taken.h5"));
}

TEST(AtomicOutput, NeverReplaceRefusesAFileMadeMeanwhileAndLeavesItUntouched) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("out.h5");
  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path, CommitMode::kNeverReplace);
  ASSERT_THAT(output.status(), IsOk());
  WriteText(output->temporary_path(), "ours");
  WriteText(path, "theirs");  // made by someone else between Prepare and Commit
  EXPECT_THAT(output->Commit(), StatusIs(absl::StatusCode::kAlreadyExists, HasSubstr("out.h5")));
  EXPECT_EQ(ReadText(path), "theirs");
  EXPECT_THAT(scratch.Entries(), ElementsAre("out.h5"));  // the temporary is gone at once
}

TEST(AtomicOutput, OfConcurrentNeverReplaceWritersExactlyOneWins) {
  constexpr int kWriters = 8;
  ScratchDirectory scratch;
  const std::string path = scratch.File("out.h5");
  std::vector<std::optional<AtomicOutput>> outputs;
  for (int i = 0; i < kWriters; ++i) {
    absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path, CommitMode::kNeverReplace);
    ASSERT_THAT(output.status(), IsOk());
    WriteText(output->temporary_path(), absl::StrCat("writer ", i));
    outputs.emplace_back(*std::move(output));
  }
  std::vector<absl::Status> results(kWriters);
  std::vector<std::thread> threads;
  for (int i = 0; i < kWriters; ++i) {
    threads.emplace_back([&, i] { results[i] = outputs[i]->Commit(); });
  }
  for (std::thread& thread : threads) thread.join();
  int winners = 0;
  for (int i = 0; i < kWriters; ++i) {
    if (results[i].ok()) {
      ++winners;
      EXPECT_EQ(ReadText(path), absl::StrCat("writer ", i));
    } else {
      EXPECT_THAT(results[i], StatusIs(absl::StatusCode::kAlreadyExists, ::testing::_));
    }
  }
  EXPECT_EQ(winners, 1);
  EXPECT_THAT(scratch.Entries(), ElementsAre("out.h5"));
}

TEST(AtomicOutput, AnAbandonedOutputLeavesNeitherFileNorTemporary) {
  ScratchDirectory scratch;
  {
    absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(scratch.File("out.h5"));
    ASSERT_THAT(output.status(), IsOk());
    WriteText(output->temporary_path(), "half of a file");
    EXPECT_THAT(scratch.Entries(), ::testing::SizeIs(1));
  }  // the run failed before Commit
  EXPECT_THAT(scratch.Entries(), IsEmpty());
}

TEST(AtomicOutput, AFailedCommitLeavesNoTemporaryAndNothingReplaced) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("out.h5");
  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path, CommitMode::kReplace);
  ASSERT_THAT(output.status(), IsOk());
  WriteText(output->temporary_path(), "new");
  // The final name became a non-empty directory meanwhile: rename(2) cannot replace it (as root
  // neither).
  std::filesystem::create_directory(path);
  WriteText(scratch.File("out.h5/keep"), "x");
  const absl::Status status = output->Commit();
  EXPECT_FALSE(status.ok());
  EXPECT_THAT(status.message(), HasSubstr("out.h5: cannot rename"));
  EXPECT_THAT(scratch.Entries(), ElementsAre("out.h5"));
  EXPECT_EQ(ReadText(scratch.File("out.h5/keep")), "x");
}

TEST(AtomicOutput, CommitWithoutAFileIsNotFoundAndASecondCommitIsRefused) {
  ScratchDirectory scratch;
  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(scratch.File("out.h5"));
  ASSERT_THAT(output.status(), IsOk());
  EXPECT_THAT(output->Commit(), StatusIs(absl::StatusCode::kNotFound, HasSubstr("out.h5")));
  EXPECT_THAT(output->Commit(),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("committed already")));
  EXPECT_THAT(scratch.Entries(), IsEmpty());
}

TEST(AtomicOutput, AMovedOutputIsCommittedByItsNewOwnerOnly) {
  ScratchDirectory scratch;
  absl::StatusOr<AtomicOutput> prepared = AtomicOutput::Prepare(scratch.File("out.h5"));
  ASSERT_THAT(prepared.status(), IsOk());
  WriteText(prepared->temporary_path(), "new");
  {
    AtomicOutput owner(*std::move(prepared));
    // The moved-from object lives on until the end of the test; it must not remove the file.
    ASSERT_THAT(owner.Commit(), IsOk());
  }
  EXPECT_EQ(ReadText(scratch.File("out.h5")), "new");
  EXPECT_THAT(scratch.Entries(), ElementsAre("out.h5"));
}

TEST(AtomicOutput, TemporaryNamesAreUniqueAndBesideTheFinalPath) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("out.h5");
  std::set<std::string> names;
  for (int i = 0; i < 3; ++i) {
    absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path);
    ASSERT_THAT(output.status(), IsOk());
    EXPECT_THAT(output->temporary_path(), StartsWith(absl::StrCat(path, ".tmp-", ::getpid(), "-")));
    names.insert(output->temporary_path());
  }
  EXPECT_EQ(names.size(), 3u);
}

TEST(AtomicOutput, PrepareRefusesPathsThatCannotBeWritten) {
  ScratchDirectory scratch;
  std::filesystem::create_directory(scratch.File("dir"));
  EXPECT_THAT(AtomicOutput::Prepare("").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("the output path is empty")));
  EXPECT_THAT(AtomicOutput::Prepare(scratch.File("dir")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("dir: is a directory, expected the path of the output file")));
  EXPECT_THAT(AtomicOutput::Prepare(scratch.File("missing/out.h5")).status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("missing/out.h5: directory")));
  EXPECT_THAT(scratch.Entries(), ElementsAre("dir"));
}

TEST(AtomicOutput, PrepareRefusesADirectoryItCannotWrite) {
  ScratchDirectory scratch;
  const std::string directory = scratch.File("read-only");
  std::filesystem::create_directory(directory);
  ASSERT_EQ(::chmod(directory.c_str(), 0555), 0);
  ::transient::testing::AllowOthersIn(scratch.path().string());
  // Root writes into read-only directories: the check runs as user nobody then.
  EXPECT_EQ(::transient::testing::RunUnprivileged([&] {
              const absl::Status status = AtomicOutput::Prepare(directory + "/out.h5").status();
              return status.code() == absl::StatusCode::kPermissionDenied &&
                     absl::StrContains(status.message(), "is not writable");
            }),
            "");
  ::chmod(directory.c_str(), 0755);
}

TEST(AtomicOutput, WithFinalPathNamesTheFileTheUserAskedFor) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("out.h5");
  absl::StatusOr<AtomicOutput> output = AtomicOutput::Prepare(path);
  ASSERT_THAT(output.status(), IsOk());
  const absl::Status status = absl::UnavailableError(
      absl::StrCat(output->temporary_path(), ": /range_m: writing frame 3 failed (disk full?)"));
  EXPECT_THAT(WithFinalPath(status, path),
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr(absl::StrCat(path, ": /range_m: writing frame 3 failed"))));
  EXPECT_THAT(WithFinalPath(status, path).message(), ::testing::Not(HasSubstr(".tmp-")));
  // Only temporary names of that path are rewritten.
  const absl::Status other =
      absl::InternalError(absl::StrCat(path, ".tmp-notes and ", path, "2.tmp-1-2"));
  EXPECT_EQ(WithFinalPath(other, path), other);
  EXPECT_THAT(WithFinalPath(absl::OkStatus(), path), IsOk());
}

TEST(WriteTextFile, WritesAndReplacesWholeAndLeavesNoTemporary) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("summary.json");
  ASSERT_THAT(WriteTextFile(path, "{\"frames\": 1}\n"), IsOk());
  EXPECT_EQ(ReadText(path), "{\"frames\": 1}\n");
  ASSERT_THAT(WriteTextFile(path, "{}\n"), IsOk());
  EXPECT_EQ(ReadText(path), "{}\n");
  ASSERT_THAT(WriteTextFile(scratch.File("empty.txt"), ""), IsOk());
  EXPECT_EQ(ReadText(scratch.File("empty.txt")), "");
  EXPECT_THAT(scratch.Entries(), ElementsAre("empty.txt", "summary.json"));
}

TEST(WriteTextFile, RefusesWhatItCannotWriteNamingThePathAndKeepsWhatIsThere) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("kept.txt");
  WriteText(path, "old");
  EXPECT_THAT(WriteTextFile(path, "new", CommitMode::kNeverReplace),
              StatusIs(absl::StatusCode::kAlreadyExists, HasSubstr("kept.txt: exists")));
  EXPECT_EQ(ReadText(path), "old");
  EXPECT_THAT(WriteTextFile(scratch.File("missing/out.json"), "{}"),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("missing/out.json")));
  EXPECT_THAT(WriteTextFile(scratch.path().string(), "{}"),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("is a directory")));
  EXPECT_THAT(scratch.Entries(), ElementsAre("kept.txt"));
}

}  // namespace
}  // namespace transient
