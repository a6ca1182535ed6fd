// A stream's message lends the shared encoding's images instead of copying them: it serializes
// to the bytes of a message that owns copies, and gives the images back intact (under the
// sanitizers a double free or a use after free of a lent image fails here).
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"
#include "transient/service/stream_plan.h"
#include "transient/v1/transient.pb.h"

namespace transient::service {
namespace {

std::shared_ptr<const v1::Frame> SharedImages() {
  auto images = std::make_shared<v1::Frame>();
  for (int i = 0; i < 3; ++i) {
    v1::Image* image = images->add_images();
    image->set_name("slices/" + std::to_string(i));
    image->set_width(4);
    image->set_height(2);
    image->set_data(std::string(32, static_cast<char>('a' + i)));
  }
  return images;
}

v1::Frame Fields(uint64_t sequence) {
  v1::Frame fields;
  fields.set_sequence(sequence);
  fields.set_missed(2);
  fields.mutable_roi()->set_width(4);
  return fields;
}

TEST(StreamMessage, SerializesAsACopyAndGivesTheImagesBackIntact) {
  const std::shared_ptr<const v1::Frame> images = SharedImages();
  const std::string shared_before = images->SerializeAsString();
  v1::Frame copy = Fields(7);
  *copy.mutable_images() = images->images();
  {
    StreamMessage first(Fields(7), images);
    StreamMessage second(Fields(8), images);
    EXPECT_EQ(first.frame().SerializeAsString(), copy.SerializeAsString());
    EXPECT_EQ(second.frame().sequence(), 8u);
    ASSERT_EQ(second.frame().images_size(), 3);
    EXPECT_EQ(&second.frame().images(1), &images->images(1));  // lent, not copied
  }
  EXPECT_EQ(images->SerializeAsString(), shared_before);
}

// Streams of one plan serialize the same images at once, as the server's threads do.
TEST(StreamMessage, ManyStreamsSerializeTheSharedImagesConcurrently) {
  const std::shared_ptr<const v1::Frame> images = SharedImages();
  v1::Frame copy = Fields(1);
  *copy.mutable_images() = images->images();
  const std::string expected = copy.SerializeAsString();
  std::vector<std::string> got(8);
  std::vector<std::thread> streams;
  for (size_t i = 0; i < got.size(); ++i) {
    streams.emplace_back([&, i] {
      for (int round = 0; round < 200; ++round) {
        StreamMessage message(Fields(1), images);
        got[i] = message.frame().SerializeAsString();
      }
    });
  }
  for (std::thread& stream : streams) stream.join();
  for (const std::string& bytes : got) EXPECT_EQ(bytes, expected);
  EXPECT_EQ(images->images_size(), 3);
}

}  // namespace
}  // namespace transient::service
