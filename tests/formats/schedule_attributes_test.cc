// The schedule attributes captures and calibrations share: what is written reads back, and each
// bad attribute is named.
#include "formats/schedule_attributes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <string>

#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/formats/h5.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

// A file with the attributes of `schedule` on its root; `edit` then changes one.
class ScheduleAttributes : public ::testing::Test {
 protected:
  void SetUp() override {
    h5::SilenceErrorStack();
    file_ =
        h5::File(H5Fcreate(scratch_.File("s.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
    ASSERT_TRUE(file_.valid());
  }
  hid_t root() const { return file_.get(); }

  ScratchDirectory scratch_;
  h5::Id file_;
};

ScheduleOptions ArccosProxy() {
  return {.base_frequency_hz = 20e6,
          .order = 5,
          .sampling = SamplingScheme::kArccos,
          .phase_steps = 6,
          .zeroth = ZerothScheme::kLowFrequencyProxy,
          .proxy_frequency_hz = 1.5e6,
          .exposure_s = 2e-3,
          .takes = 3};
}

TEST_F(ScheduleAttributes, EveryFieldReadsBackAsWritten) {
  for (const ScheduleOptions& written :
       {ArccosProxy(),
        ScheduleOptions{.base_frequency_hz = 8e6,  // the Kinect v2's
                        .order = 15,
                        .harmonics = {10, 2, 15},
                        .buckets = 3,
                        .sampling = SamplingScheme::kFourBucket,
                        .phase_steps = 1,
                        .zeroth = ZerothScheme::kEstimated},
        ScheduleOptions{.sampling = SamplingScheme::kFourBucket,
                       .phase_steps = 1,
                       .zeroth = ZerothScheme::kEstimated}}) {
    ASSERT_THAT(written.Validate(), IsOk());
    ASSERT_THAT(WriteScheduleAttributes(root(), written), IsOk());  // replaces the last ones
    absl::StatusOr<ScheduleOptions> read =
        ReadScheduleAttributes(root(), "s.h5: /", TakesAttribute::kRequired);
    ASSERT_THAT(read.status(), IsOk());
    EXPECT_EQ(read->base_frequency_hz, written.base_frequency_hz);
    EXPECT_EQ(read->order, written.order);
    EXPECT_EQ(read->sampling, written.sampling);
    EXPECT_EQ(read->phase_steps, written.phase_steps);
    EXPECT_EQ(read->zeroth, written.zeroth);
    EXPECT_EQ(read->proxy_frequency_hz, written.proxy_frequency_hz);
    EXPECT_EQ(read->exposure_s, written.exposure_s);
    EXPECT_EQ(read->takes, written.takes);
    EXPECT_EQ(read->buckets, written.buckets);
    EXPECT_EQ(read->harmonics, written.harmonics);  // the Kinect's set does not stay behind
  }
}

TEST_F(ScheduleAttributes, FilesWithoutBucketsOrHarmonicsAreFourBucketOneToM) {
  ASSERT_THAT(WriteScheduleAttributes(root(), ArccosProxy()), IsOk());
  ASSERT_GE(H5Adelete(root(), "buckets"), 0);
  absl::StatusOr<ScheduleOptions> read =
      ReadScheduleAttributes(root(), "s.h5: /", TakesAttribute::kRequired);
  ASSERT_THAT(read.status(), IsOk());
  EXPECT_EQ(read->buckets, 4);
  EXPECT_TRUE(read->harmonics.empty());
}

TEST_F(ScheduleAttributes, AMissingTakesIsOneOnlyWhereOptional) {
  ASSERT_THAT(WriteScheduleAttributes(root(), ArccosProxy()), IsOk());
  ASSERT_GE(H5Adelete(root(), "takes"), 0);
  absl::StatusOr<ScheduleOptions> optional =
      ReadScheduleAttributes(root(), "s.h5: /", TakesAttribute::kOptional);
  ASSERT_THAT(optional.status(), IsOk());
  EXPECT_EQ(optional->takes, 1);
  EXPECT_THAT(
      ReadScheduleAttributes(root(), "s.h5: /", TakesAttribute::kRequired).status(),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("s.h5: /: missing attribute takes")));
  // Where it is there, an optional takes is still checked.
  ASSERT_THAT(h5::WriteInt64Attribute(root(), "takes", 0), IsOk());
  EXPECT_THAT(ReadScheduleAttributes(root(), "s.h5: /", TakesAttribute::kOptional).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("attribute takes: expected an integer in 1..1048576, found 0")));
}

TEST_F(ScheduleAttributes, EachBadAttributeIsNamed) {
  struct Case {
    const char* name;
    void (*edit)(hid_t);
    const char* message;
  };
  const Case cases[] = {
      {"frequency",
       [](hid_t g) { ASSERT_THAT(h5::WriteDoubleAttribute(g, "base_frequency_hz", 0), IsOk()); },
       "s.h5: /: attribute base_frequency_hz: expected a finite value > 0, found 0"},
      {"order", [](hid_t g) { ASSERT_THAT(h5::WriteInt64Attribute(g, "order", 17), IsOk()); },
       "s.h5: /: attribute order: expected an integer in 1..16, found 17"},
      {"sampling",
       [](hid_t g) { ASSERT_THAT(h5::WriteStringAttribute(g, "sampling", "sine"), IsOk()); },
       "s.h5: /: attribute sampling:"},
      {"phase steps",
       [](hid_t g) { ASSERT_THAT(h5::WriteDoubleAttribute(g, "phase_steps", 2.5), IsOk()); },
       "s.h5: /: attribute phase_steps: expected an integer in 1..1048576, found 2.5"},
      {"zeroth",
       [](hid_t g) { ASSERT_THAT(h5::WriteStringAttribute(g, "zeroth", "guess"), IsOk()); },
       "s.h5: /: attribute zeroth:"},
      {"proxy",
       [](hid_t g) { ASSERT_THAT(h5::WriteDoubleAttribute(g, "proxy_frequency_hz", -1), IsOk()); },
       "s.h5: /: attribute proxy_frequency_hz: expected a finite value >= 0, found -1"},
      {"exposure", [](hid_t g) { H5Adelete(g, "exposure_s"); },
       "s.h5: /: missing attribute exposure_s"},
      {"takes", [](hid_t g) { ASSERT_THAT(h5::WriteStringAttribute(g, "takes", "3"), IsOk()); },
       "s.h5: /: attribute takes: expected a number (float64), found string"},
      {"buckets", [](hid_t g) { ASSERT_THAT(h5::WriteInt64Attribute(g, "buckets", 2), IsOk()); },
       "s.h5: /: attribute buckets: expected an integer in 3..16, found 2"},
      {"harmonics",
       [](hid_t g) { ASSERT_THAT(h5::WriteStringAttribute(g, "harmonics", "2,a"), IsOk()); },
       "s.h5: /: attribute harmonics: harmonic list '2,a': 'a' is not an integer"},
      {"depth camera",
       [](hid_t g) { ASSERT_THAT(h5::WriteStringAttribute(g, "sampling", "depth"), IsOk()); },
       "s.h5: /: attribute sampling: sampling scheme 'depth' is a depth camera's"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    ASSERT_THAT(WriteScheduleAttributes(root(), ArccosProxy()), IsOk());
    c.edit(root());
    EXPECT_THAT(ReadScheduleAttributes(root(), "s.h5: /", TakesAttribute::kRequired).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(c.message)));
  }
}

TEST_F(ScheduleAttributes, ADepthCamerasScheduleIsNeverWritten) {
  ScheduleOptions depth;
  depth.sampling = SamplingScheme::kDepth;
  depth.max_depth_m = 8.0;
  ASSERT_THAT(depth.Validate(), IsOk());
  EXPECT_THAT(WriteScheduleAttributes(root(), depth),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("the source delivers depth, not modulated captures")));
  EXPECT_EQ(H5Aexists(root(), "sampling"), 0) << "nothing written";
}

}  // namespace
}  // namespace transient
