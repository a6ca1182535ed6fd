// The registry of source schemes: finding a scheme, the generic URI parser's bad inputs, and
// the questions the daemon asks instead of taking URIs apart itself (calibration scene,
// changing the takes, embedded calibration, whether a source waits for its consumer).
#include "transient/drivers/source_registry.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "absl/strings/str_cat.h"
#include "source_uri.h"
#include "tests/formats/test_captures.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/drivers/simulator.h"
#include "transient/formats/capture_file.h"

namespace transient {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Pair;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

TEST(SourceRegistry, EverySchemeIsFoundByItsUrisAndDescribed) {
  ASSERT_GE(SourceSchemes().size(), 2u);
  const std::string described = DescribeSourceSchemes();
  for (const SourceScheme* scheme : SourceSchemes()) {
    absl::StatusOr<const SourceScheme*> found =
        FindSourceScheme(absl::StrCat(scheme->name, ":x?a=b"));
    ASSERT_THAT(found.status(), IsOk());
    EXPECT_EQ(*found, scheme);
    EXPECT_NE(scheme->open, nullptr) << scheme->name;
    EXPECT_EQ(scheme->capabilities.calibration_scene, scheme->calibration_source != nullptr);
    EXPECT_EQ(scheme->capabilities.adjustable_takes, scheme->with_takes != nullptr);
    EXPECT_THAT(described, HasSubstr(std::string(scheme->syntax)));
    for (const SourceKey& key : scheme->keys) {
      EXPECT_THAT(described, HasSubstr(absl::StrCat("  ", key.name, " (default ")));
    }
  }
}

TEST(SourceRegistry, AnUnknownSchemeNamesTheUriAndTheSchemesThereAre) {
  for (const char* uri : {"v4l2x:/dev/video0", "mirrors", "", ":x"}) {
    EXPECT_THAT(FindSourceScheme(uri).status(),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         AllOf(HasSubstr(absl::StrCat("unknown source '", uri, "'")),
                               HasSubstr("sim:<scene>"), HasSubstr("replay:<capture.h5>"))));
    EXPECT_THAT(OpenSource(uri).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("unknown source")));
  }
}

TEST(SourceUri, SplitsSchemeTargetAndKeysInOrder) {
  absl::StatusOr<internal::SourceUri> uri = internal::ParseSourceUri("sim:mirrors?m=4&f=2e7");
  ASSERT_THAT(uri.status(), IsOk());
  EXPECT_EQ(uri->scheme, "sim");
  EXPECT_EQ(uri->target, "mirrors");
  EXPECT_THAT(uri->keys, ElementsAre(Pair("m", "4"), Pair("f", "2e7")));
  absl::StatusOr<internal::SourceUri> bare = internal::ParseSourceUri("replay:/a/b.h5");
  ASSERT_THAT(bare.status(), IsOk());
  EXPECT_EQ(bare->target, "/a/b.h5");
  EXPECT_TRUE(bare->keys.empty());
}

TEST(SourceUri, FormatsBackWithAKeySetOrAdded) {
  absl::StatusOr<internal::SourceUri> uri = internal::ParseSourceUri("v4l2:/dev/video0?m=4&f=2e7");
  ASSERT_THAT(uri.status(), IsOk());
  EXPECT_EQ(internal::FormatSourceUri(*uri), "v4l2:/dev/video0?m=4&f=2e7");
  internal::SetSourceUriKey(&*uri, "m", "2");
  internal::SetSourceUriKey(&*uri, "takes", "3");
  EXPECT_EQ(internal::FormatSourceUri(*uri), "v4l2:/dev/video0?m=2&f=2e7&takes=3");
  absl::StatusOr<internal::SourceUri> bare = internal::ParseSourceUri("replay:/a/b.h5");
  ASSERT_THAT(bare.status(), IsOk());
  EXPECT_EQ(internal::FormatSourceUri(*bare), "replay:/a/b.h5");
}

TEST(SourceUri, PercentEscapesAreDecodedAndStrayPercentsKept) {
  EXPECT_EQ(internal::PercentDecoded("Output%20Mode"), "Output Mode");
  EXPECT_EQ(internal::PercentDecoded("a%2Cb%2c"), "a,b,");
  EXPECT_EQ(internal::PercentDecoded("100%"), "100%");
  EXPECT_EQ(internal::PercentDecoded("%2"), "%2");
  EXPECT_EQ(internal::PercentDecoded("%zz%41"), "%zzA");
  EXPECT_THAT(internal::BadKeyValue("replay:x.h5?loop=2", "loop", "2", "0 or 1"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       ::testing::Eq("replay:x.h5?loop=2: loop = '2'; expected 0 or 1")));
}

TEST(SourceUri, MalformedParametersAndRepeatedKeysAreRefusedByName) {
  EXPECT_THAT(internal::ParseSourceUri("no scheme").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("is not a source URI")));
  for (const char* pair : {"m", "m=", "=3"}) {
    EXPECT_THAT(internal::ParseSourceUri(absl::StrCat("sim:mirrors?", pair)).status(),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr(absl::StrCat("sim: malformed parameter '", pair, "'"))));
  }
  EXPECT_THAT(internal::ParseSourceUri("replay:x.h5?loop=1&loop=0").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("key loop given twice")));
}

TEST(SourceRegistry, TheSimulatorsCalibrationSceneKeepsTheCameraAndRunsFast) {
  absl::StatusOr<std::string> uri =
      CalibrationSourceFor("sim:mirrors?width=32&height=24&camera_seed=7&m=4&pace=realtime");
  ASSERT_THAT(uri.status(), IsOk());
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(*uri);
  ASSERT_THAT(options.status(), IsOk());
  EXPECT_EQ(options->scene, "calibration");
  EXPECT_EQ(options->width, 32);
  EXPECT_EQ(options->height, 24);
  EXPECT_EQ(options->camera_seed, 7u);
  EXPECT_EQ(options->schedule.order, 4);
  EXPECT_EQ(options->pace, Pace::kFast);
  EXPECT_EQ(options->frames, 0);
}

TEST(SourceRegistry, AReplayHasNoCalibrationSceneAndFixesItsTakes) {
  EXPECT_THAT(CalibrationSourceFor("replay:capture.h5").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("replay:capture.h5"), HasSubstr("no calibration scene"))));
  EXPECT_THAT(SourceUriWithTakes("replay:capture.h5", 2).status(),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("fixes its schedule")));
}

TEST(SourceRegistry, TheSimulatorsTakesChangeInItsUriAndImpossibleOnesAreRefused) {
  absl::StatusOr<std::string> uri = SourceUriWithTakes("sim:mirrors?width=32&height=24", 3);
  ASSERT_THAT(uri.status(), IsOk());
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(*uri);
  ASSERT_THAT(options.status(), IsOk());
  EXPECT_EQ(options->schedule.takes, 3);
  EXPECT_EQ(options->width, 32);
  EXPECT_THAT(SourceUriWithTakes("sim:mirrors", 0).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("takes")));
  EXPECT_THAT(SourceUriWithTakes("sim:kitchen", 2).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("unknown scene")));
}

TEST(SourceRegistry, AFastReplayWaitsForItsConsumerAndCarriesItsCalibration) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("capture.h5");
  {
    const CameraInfo camera = testing::TestCamera();
    const AcquisitionSchedule schedule = testing::TestSchedule();
    absl::StatusOr<CaptureWriter> writer =
        CaptureWriter::Create(path, camera, schedule, testing::TestOptions());
    ASSERT_THAT(writer.status(), IsOk());
    ASSERT_THAT(writer->EmbedCalibration(testing::TestCalibration(camera, schedule)), IsOk());
    for (int64_t i = 0; i < 10; ++i) {
      ASSERT_THAT(writer->Append(testing::TestFrame(camera, schedule, i, false)), IsOk());
    }
    ASSERT_THAT(writer->Close(), IsOk());
  }
  absl::StatusOr<std::unique_ptr<CaptureSource>> fast =
      OpenSource(absl::StrCat("replay:", path, "?pace=fast"));
  ASSERT_THAT(fast.status(), IsOk());
  EXPECT_TRUE((*fast)->capabilities().waits_for_consumer);
  std::string origin;
  const CalibrationTable* table = (*fast)->embedded_calibration(&origin);
  ASSERT_NE(table, nullptr);
  EXPECT_EQ(table->geometry, testing::TestCamera().geometry);
  EXPECT_EQ(origin, absl::StrCat(path, ": /calibration"));

  absl::StatusOr<std::unique_ptr<CaptureSource>> paced = OpenSource(absl::StrCat("replay:", path));
  ASSERT_THAT(paced.status(), IsOk());
  EXPECT_FALSE((*paced)->capabilities().waits_for_consumer);
  absl::StatusOr<std::unique_ptr<CaptureSource>> sim = OpenSource("sim:mirrors?width=8&height=8");
  ASSERT_THAT(sim.status(), IsOk());
  EXPECT_FALSE((*sim)->capabilities().waits_for_consumer);
  EXPECT_EQ((*sim)->embedded_calibration(nullptr), nullptr);
}

TEST(SourceRegistry, ARecordingWithoutACalibrationCarriesNone) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("bare.h5");
  testing::WriteTestCapture(path, 10, testing::TestOptions());
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(absl::StrCat("replay:", path));
  ASSERT_THAT(source.status(), IsOk());
  std::string origin = "unchanged";
  EXPECT_EQ((*source)->embedded_calibration(&origin), nullptr);
  EXPECT_EQ(origin, "unchanged");
}

}  // namespace
}  // namespace transient
