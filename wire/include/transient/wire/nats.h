// transient.v1 frames over NATS JetStream (README, "Many cameras, many machines"), both sides:
// the subjects and stream of a camera, the headers of a message, how a frame is split into
// messages no larger than the server takes, and a connection with the credentials of
// ConnectOptions (files only, never secrets on command lines).
//
// A frame's products go to `transient.<camera>.<product>` (product in lower case:
// `transient.lab1.moment_state`), kept by the JetStream stream `TRANSIENT_<camera>` within the
// limits the publisher sets. Each message carries a serialized v1::Frame holding one product's
// images, or one part of it: a frame larger than the server's max_payload is cut into parts
// sent in order, and a consumer joins them (FrameAssembler).
#pragma once

#include <nats/nats.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/notification.h"
#include "transient/v1/transient.pb.h"

namespace transient::wire {

// Headers of every message (NATS headers, JetStream keeps them).
inline constexpr char kNatsSequenceHeader[] = "Transient-Sequence";         // Frame.sequence
inline constexpr char kNatsCaptureTimeHeader[] = "Transient-Capture-Time";  // seconds, %.9f
inline constexpr char kNatsProductHeader[] = "Transient-Product";           // MOMENT_STATE
inline constexpr char kNatsEncodingHeader[] = "Transient-Encoding";         // FLOAT32/ZSTD
inline constexpr char kNatsPartHeader[] = "Transient-Part";                 // "k/n", k = 1..n
inline constexpr char kNatsBaseFrequencyHeader[] = "Transient-Base-Frequency-Hz";  // f, %.17g

// A camera's name in subjects and the stream: 1..64 of [A-Za-z0-9_-]. InvalidArgument naming
// the character otherwise.
absl::Status CheckNatsCameraName(absl::string_view camera);
// "transient.<camera>.<product in lower case>".
std::string NatsSubject(absl::string_view camera, v1::Product product);
// "transient.<camera>.>": every product of the camera.
std::string NatsCameraSubjects(absl::string_view camera);
// "TRANSIENT_<camera>".
std::string NatsStreamName(absl::string_view camera);

// Where and as whom to connect. Secrets come from files.
struct NatsConnectOptions {
  // nats://host:port (tls://host:port for TLS), several separated by commas: the servers of one
  // cluster, tried in turn and on reconnection.
  std::string servers;
  std::string name;        // the connection's name, as the server's monitoring shows it
  std::string user_file;   // "user:password" on one line (chmod 600)
  std::string creds_file;  // a user JWT with its nkey seed (nsc's .creds file; chmod 600)
  std::string ca_file;     // PEM: the CA that signed the server's certificate (TLS)
  std::string cert_file;   // PEM client certificate (the server's `verify`), with key_file
  std::string key_file;
  // How long one connection attempt and a JetStream API call may take.
  int64_t timeout_ms = 5000;
};

// The servers of `list` (comma-separated URLs); InvalidArgument naming a bad one.
absl::StatusOr<std::vector<std::string>> ParseNatsServers(absl::string_view list);

// The value of header `key` of `msg`, or "" when it has none.
absl::string_view NatsHeader(natsMsg* msg, const char* key);

// The absl::Status of subscribing to a camera's stream that returned `status` and JetStream's
// `code`: NotFound naming the stream and the publisher that would make it when the camera has
// none, else FromNatsStatus(status, what).
absl::Status FromNatsSubscribeStatus(natsStatus status, jsErrCode code, absl::string_view what,
                                     absl::string_view camera);

// The absl::Status of a NATS call that returned `status`: the library's last error text, and
// Unauthenticated for refused credentials, Unavailable for servers that cannot be reached.
absl::Status FromNatsStatus(natsStatus status, absl::string_view what);

// A connection to a NATS server (or cluster) with its JetStream context. Reconnects for ever
// (every 250 ms) once connected; while disconnected, publishes fail at once rather than being
// buffered (the reconnect buffer is off). Thread-safe as cnats is.
class NatsConnection {
 public:
  // Connects. `background`: when no server answers yet, returns a connection that keeps trying
  // (a publisher that starts before its server); otherwise Unavailable. Unauthenticated for
  // refused credentials, InvalidArgument for unreadable or world-readable secret files.
  // `jetstream`: the JetStream context's options (asynchronous publishing's handlers); null =
  // the defaults with options.timeout_ms.
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<NatsConnection>> Open(
      const NatsConnectOptions& options, bool background, const jsOptions* jetstream = nullptr);
  ~NatsConnection();
  NatsConnection(const NatsConnection&) = delete;
  NatsConnection& operator=(const NatsConnection&) = delete;

  natsConnection* connection() const { return nc_; }
  jsCtx* jetstream() const { return js_; }
  bool connected() const;
  // Times the connection was lost, and won back.
  int64_t disconnects() const { return disconnects_.load(); }
  int64_t reconnects() const { return reconnects_.load(); }
  // The largest message the server takes (bytes), 0 before the first connection.
  int64_t max_payload() const;
  const std::string& servers() const { return servers_; }

 private:
  NatsConnection() = default;
  static void OnConnected(natsConnection* nc, void* closure);
  static void OnClosed(natsConnection* nc, void* closure);
  static void OnDisconnected(natsConnection* nc, void* closure);
  static void OnReconnected(natsConnection* nc, void* closure);

  std::string servers_;
  natsOptions* options_ = nullptr;
  natsConnection* nc_ = nullptr;
  jsCtx* js_ = nullptr;
  std::atomic<int64_t> disconnects_{0};
  std::atomic<int64_t> reconnects_{0};
  // cnats runs the callbacks above on a thread of its own, after natsConnection_Close returns;
  // the closed callback comes last, so the destructor waits for it before this object goes.
  absl::Notification closed_;  // safe to destroy once waited for
};

// One message of a frame: its subject's product, part k of n, and the bytes.
struct NatsPart {
  int index = 1;  // 1..count
  int count = 1;
  std::string data;
};

// `frame` serialized and cut into parts of at most `max_part_bytes` (>= 1).
std::vector<NatsPart> SplitFrame(const v1::Frame& frame, int64_t max_part_bytes);

// One message to publish: its subject, headers and bytes.
struct NatsMessage {
  std::string subject;
  std::vector<std::pair<std::string, std::string>> headers;
  std::string data;
};

// The messages of one frame of `camera`: for each of `products` (in order) a v1::Frame with
// that product's images (the frame itself when it is the only one), on NatsSubject(camera,
// product), cut into parts of at most max_part_bytes, each with the headers above. `encoding`
// names the images' encoding and compression ("FLOAT32/NONE").
std::vector<NatsMessage> FrameMessages(v1::Frame frame, absl::string_view camera,
                                       const std::vector<v1::Product>& products,
                                       absl::string_view encoding, double base_frequency_hz,
                                       int64_t max_part_bytes);
// `message` as a natsMsg the caller owns (natsMsg_Destroy), or why not.
absl::StatusOr<natsMsg*> ToNatsMsg(const NatsMessage& message);

// Room left in a message for its headers below the server's max_payload.
inline constexpr int64_t kNatsHeaderRoom = 4096;

// Joins the parts of frames arriving in order on one subject. A part out of turn (a frame's
// first parts were not received: a consumer that started in its middle, or parts dropped while
// the publisher lost its server) abandons the frame being joined, counted in abandoned().
class FrameAssembler {
 public:
  enum class Result { kIncomplete, kFrame, kBad };
  // Adds part `part` ("k/n" from the header; empty = a whole frame) of frame `sequence`. kFrame
  // when *frame is complete; kBad when the header or the joined bytes are not a frame
  // (*error says what).
  Result Add(uint64_t sequence, absl::string_view part, absl::string_view data, v1::Frame* frame,
             std::string* error);
  int64_t abandoned() const { return abandoned_; }

 private:
  uint64_t sequence_ = 0;
  int next_ = 0;  // the part expected next, 0 = none in progress
  int count_ = 0;
  std::string bytes_;
  int64_t abandoned_ = 0;
  bool abandoned_any_ = false;
  uint64_t last_abandoned_ = 0;
};

}  // namespace transient::wire
