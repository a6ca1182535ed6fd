// NATS subjects, connections and the parts of a frame (nats.h).
#include "transient/wire/nats.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "transient/wire/credentials.h"

namespace transient::wire {

absl::Status CheckNatsCameraName(absl::string_view camera) {
  if (camera.empty() || camera.size() > 64) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera name \"", camera, "\": expected 1..64 of A-Z a-z 0-9 _ -"));
  }
  for (char c : camera) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) {
      return absl::InvalidArgumentError(
          absl::StrCat("camera name \"", camera, "\": '", std::string(1, c),
                       "' is not allowed in a NATS subject token; expected A-Z a-z 0-9 _ -"));
    }
  }
  return absl::OkStatus();
}

std::string NatsSubject(absl::string_view camera, v1::Product product) {
  return absl::StrCat("transient.", camera, ".", absl::AsciiStrToLower(v1::Product_Name(product)));
}

std::string NatsCameraSubjects(absl::string_view camera) {
  return absl::StrCat("transient.", camera, ".>");
}

std::string NatsStreamName(absl::string_view camera) { return absl::StrCat("TRANSIENT_", camera); }

absl::StatusOr<std::vector<std::string>> ParseNatsServers(absl::string_view list) {
  std::vector<std::string> servers;
  for (absl::string_view url : absl::StrSplit(list, ',', absl::SkipWhitespace())) {
    url = absl::StripAsciiWhitespace(url);
    absl::string_view rest = url;
    if (!absl::ConsumePrefix(&rest, "nats://") && !absl::ConsumePrefix(&rest, "tls://")) {
      return absl::InvalidArgumentError(
          absl::StrCat("NATS server \"", url, "\": expected nats://HOST:PORT or tls://HOST:PORT"));
    }
    const size_t colon = rest.rfind(':');
    int port = 0;
    if (colon == absl::string_view::npos || colon == 0 ||
        !absl::SimpleAtoi(rest.substr(colon + 1), &port) || port < 1 || port > 65535) {
      return absl::InvalidArgumentError(
          absl::StrCat("NATS server \"", url, "\": expected a host and a port 1..65535"));
    }
    servers.emplace_back(url);
  }
  if (servers.empty()) {
    return absl::InvalidArgumentError("NATS servers: expected nats://HOST:PORT[,...]");
  }
  return servers;
}

absl::Status FromNatsStatus(natsStatus status, absl::string_view what) {
  if (status == NATS_OK) return absl::OkStatus();
  natsStatus last = NATS_OK;
  const char* text = nats_GetLastError(&last);
  const std::string message = absl::StrCat(what, ": ", natsStatus_GetText(status),
                                           text != nullptr && *text != '\0' && last == status
                                               ? absl::StrCat(" (", text, ")")
                                               : std::string());
  switch (status) {
    case NATS_CONNECTION_AUTH_FAILED:
    case NATS_NOT_PERMITTED:
      return absl::UnauthenticatedError(message);
    case NATS_NO_SERVER:
    case NATS_IO_ERROR:
    case NATS_CONNECTION_CLOSED:
    case NATS_CONNECTION_DISCONNECTED:
    case NATS_STALE_CONNECTION:
    case NATS_NOT_YET_CONNECTED:
    case NATS_NO_RESPONDERS:
      return absl::UnavailableError(message);
    case NATS_TIMEOUT:
      return absl::DeadlineExceededError(message);
    case NATS_NOT_FOUND:
      return absl::NotFoundError(message);
    case NATS_INVALID_ARG:
    case NATS_INVALID_SUBJECT:
    case NATS_ADDRESS_MISSING:
      return absl::InvalidArgumentError(message);
    case NATS_SECURE_CONNECTION_WANTED:
    case NATS_SECURE_CONNECTION_REQUIRED:
    case NATS_SSL_ERROR:
      return absl::UnavailableError(absl::StrCat(message, "; check the TLS options"));
    default:
      return absl::InternalError(message);
  }
}

absl::string_view NatsHeader(natsMsg* msg, const char* key) {
  const char* value = nullptr;
  if (natsMsgHeader_Get(msg, key, &value) != NATS_OK || value == nullptr) return {};
  return value;
}

absl::Status FromNatsSubscribeStatus(natsStatus status, jsErrCode code, absl::string_view what,
                                     absl::string_view camera) {
  constexpr int kStreamNotFound = 10059;  // JetStream's JSStreamNotFoundErr
  absl::Status why = FromNatsStatus(status, what);
  if (status == NATS_NOT_FOUND || static_cast<int>(code) == kStreamNotFound) {
    return absl::NotFoundError(absl::StrCat(why.message(), ": no stream ", NatsStreamName(camera),
                                            "; has a transientd --publish --nats-camera ", camera,
                                            " run against this server?"));
  }
  return why;
}

namespace {

// The options of `o`, or why not. `options` is destroyed on error.
absl::Status Configure(const NatsConnectOptions& o, const std::vector<std::string>& servers,
                       natsOptions* options) {
  std::vector<const char*> urls;
  for (const std::string& url : servers) urls.push_back(url.c_str());
  bool tls = !o.ca_file.empty() || !o.cert_file.empty();
  for (const std::string& url : servers) tls = tls || url.rfind("tls://", 0) == 0;
  natsStatus s = natsOptions_SetServers(options, urls.data(), static_cast<int>(urls.size()));
  if (s == NATS_OK && !o.name.empty()) s = natsOptions_SetName(options, o.name.c_str());
  if (s == NATS_OK) s = natsOptions_SetTimeout(options, o.timeout_ms);
  if (s == NATS_OK) s = natsOptions_SetAllowReconnect(options, true);
  if (s == NATS_OK) s = natsOptions_SetMaxReconnect(options, -1);  // for ever
  if (s == NATS_OK) s = natsOptions_SetReconnectWait(options, 250);
  // While disconnected, a publish fails at once: frames are dropped and counted, not buffered.
  if (s == NATS_OK) s = natsOptions_SetReconnectBufSize(options, 0);
  if (s == NATS_OK) s = natsOptions_SetPingInterval(options, 2000);
  if (s != NATS_OK) return FromNatsStatus(s, "NATS options");
  if (!o.user_file.empty()) {
    absl::StatusOr<std::pair<std::string, std::string>> user =
        ReadUserPasswordFile("--nats-user-file", o.user_file);
    if (!user.ok()) return user.status();
    s = natsOptions_SetUserInfo(options, user->first.c_str(), user->second.c_str());
    if (s != NATS_OK) return FromNatsStatus(s, "NATS user");
  }
  if (!o.creds_file.empty()) {
    if (absl::Status status = CheckSecretFile("--nats-creds", o.creds_file); !status.ok()) {
      return status;
    }
    s = natsOptions_SetUserCredentialsFromFiles(options, o.creds_file.c_str(), nullptr);
    if (s != NATS_OK) return FromNatsStatus(s, absl::StrCat("NATS credentials ", o.creds_file));
  }
  if (o.cert_file.empty() != o.key_file.empty()) {
    return absl::InvalidArgumentError(
        "NATS TLS: a client certificate needs its key, and a key "
        "its certificate");
  }
  if (tls) {
    s = natsOptions_SetSecure(options, true);
    if (s == NATS_OK && !o.ca_file.empty()) {
      if (absl::StatusOr<std::string> ca = ReadPemFile("--nats-ca", o.ca_file, false); !ca.ok()) {
        return ca.status();
      }
      s = natsOptions_LoadCATrustedCertificates(options, o.ca_file.c_str());
    }
    if (s == NATS_OK && !o.cert_file.empty()) {
      if (absl::StatusOr<std::string> key = ReadPemFile("--nats-key", o.key_file, true);
          !key.ok()) {
        return key.status();
      }
      s = natsOptions_LoadCertificatesChain(options, o.cert_file.c_str(), o.key_file.c_str());
    }
    if (s != NATS_OK) return FromNatsStatus(s, "NATS TLS files");
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::unique_ptr<NatsConnection>> NatsConnection::Open(const NatsConnectOptions& o,
                                                                     bool background,
                                                                     const jsOptions* jetstream) {
  absl::StatusOr<std::vector<std::string>> servers = ParseNatsServers(o.servers);
  if (!servers.ok()) return servers.status();
  std::unique_ptr<NatsConnection> c(new NatsConnection());
  c->servers_ = o.servers;
  if (natsStatus s = natsOptions_Create(&c->options_); s != NATS_OK) {
    return FromNatsStatus(s, "NATS options");
  }
  if (absl::Status status = Configure(o, *servers, c->options_); !status.ok()) return status;
  natsOptions_SetDisconnectedCB(c->options_, &NatsConnection::OnDisconnected, c.get());
  natsOptions_SetReconnectedCB(c->options_, &NatsConnection::OnReconnected, c.get());
  natsOptions_SetClosedCB(c->options_, &NatsConnection::OnClosed, c.get());
  natsStatus s = natsConnection_Connect(&c->nc_, c->options_);
  if (s == NATS_NO_SERVER && background) {
    // No server answers yet (refused credentials or TLS are errors now): keep trying.
    // With a callback the library connects in the background; without one it would block.
    natsOptions_SetRetryOnFailedConnect(c->options_, true, &NatsConnection::OnConnected, c.get());
    s = natsConnection_Connect(&c->nc_, c->options_);
    if (s == NATS_NOT_YET_CONNECTED) s = NATS_OK;
  }
  if (s != NATS_OK) {
    return FromNatsStatus(s, absl::StrCat("connecting to NATS at ", o.servers));
  }
  jsOptions js_options;
  jsOptions_Init(&js_options);
  if (jetstream != nullptr) js_options = *jetstream;
  if (js_options.Wait == 0) js_options.Wait = o.timeout_ms;
  if (s = natsConnection_JetStream(&c->js_, c->nc_, &js_options); s != NATS_OK) {
    return FromNatsStatus(s, "NATS JetStream context");
  }
  return c;
}

NatsConnection::~NatsConnection() {
  if (js_ != nullptr) jsCtx_Destroy(js_);
  if (nc_ != nullptr) {
    natsConnection_Close(nc_);
    // The callbacks still queued (disconnected, then closed) point at this object.
    closed_.WaitForNotificationWithTimeout(absl::Seconds(5));
  }
  if (nc_ != nullptr) natsConnection_Destroy(nc_);
  if (options_ != nullptr) natsOptions_Destroy(options_);
}

bool NatsConnection::connected() const {
  return nc_ != nullptr && natsConnection_Status(nc_) == NATS_CONN_STATUS_CONNECTED;
}

int64_t NatsConnection::max_payload() const {
  return nc_ != nullptr && connected() ? natsConnection_GetMaxPayload(nc_) : 0;
}

void NatsConnection::OnDisconnected(natsConnection*, void* closure) {
  static_cast<NatsConnection*>(closure)->disconnects_.fetch_add(1);
}

void NatsConnection::OnConnected(natsConnection*, void*) {}

void NatsConnection::OnClosed(natsConnection*, void* closure) {
  static_cast<NatsConnection*>(closure)->closed_.Notify();
}

void NatsConnection::OnReconnected(natsConnection*, void* closure) {
  static_cast<NatsConnection*>(closure)->reconnects_.fetch_add(1);
}

std::vector<NatsPart> SplitFrame(const v1::Frame& frame, int64_t max_part_bytes) {
  std::string bytes = frame.SerializeAsString();
  const size_t step = static_cast<size_t>(std::max<int64_t>(1, max_part_bytes));
  const int count = static_cast<int>(std::max<size_t>(1, (bytes.size() + step - 1) / step));
  std::vector<NatsPart> parts;
  if (count == 1) {
    parts.push_back({1, 1, std::move(bytes)});
    return parts;
  }
  for (int k = 0; k < count; ++k) {
    parts.push_back({k + 1, count, bytes.substr(static_cast<size_t>(k) * step, step)});
  }
  return parts;
}

std::vector<NatsMessage> FrameMessages(v1::Frame frame, absl::string_view camera,
                                       const std::vector<v1::Product>& products,
                                       absl::string_view encoding, double base_frequency_hz,
                                       int64_t max_part_bytes) {
  std::vector<NatsMessage> messages;
  const std::string sequence = absl::StrCat(frame.sequence());
  char capture[64];
  std::snprintf(capture, sizeof(capture), "%.9f", frame.capture_time_s());
  char frequency[64];
  std::snprintf(frequency, sizeof(frequency), "%.17g", base_frequency_hz);
  // Several products: each image moves once into its product's frame, no image is copied.
  google::protobuf::RepeatedPtrField<v1::Image> images;
  if (products.size() > 1) images.Swap(frame.mutable_images());
  for (v1::Product product : products) {
    v1::Frame one;
    const v1::Frame* whole = &frame;
    if (products.size() > 1) {
      one = frame;  // without images
      for (v1::Image& image : images) {
        if (image.product() == product) *one.add_images() = std::move(image);
      }
      whole = &one;
    }
    const std::string subject = NatsSubject(camera, product);
    for (NatsPart& part : SplitFrame(*whole, max_part_bytes)) {
      NatsMessage& m = messages.emplace_back();
      m.subject = subject;
      m.headers = {{kNatsSequenceHeader, sequence},
                   {kNatsCaptureTimeHeader, capture},
                   {kNatsProductHeader, v1::Product_Name(product)},
                   {kNatsEncodingHeader, std::string(encoding)},
                   {kNatsBaseFrequencyHeader, frequency},
                   {kNatsPartHeader, absl::StrCat(part.index, "/", part.count)}};
      m.data = std::move(part.data);
    }
  }
  return messages;
}

absl::StatusOr<natsMsg*> ToNatsMsg(const NatsMessage& message) {
  natsMsg* msg = nullptr;
  natsStatus s = natsMsg_Create(&msg, message.subject.c_str(), nullptr, message.data.data(),
                                static_cast<int>(message.data.size()));
  for (const auto& [key, value] : message.headers) {
    if (s == NATS_OK) s = natsMsgHeader_Set(msg, key.c_str(), value.c_str());
  }
  if (s != NATS_OK) {
    natsMsg_Destroy(msg);
    return FromNatsStatus(s, absl::StrCat("a message for ", message.subject));
  }
  return msg;
}

FrameAssembler::Result FrameAssembler::Add(uint64_t sequence, absl::string_view part,
                                           absl::string_view data, v1::Frame* frame,
                                           std::string* error) {
  int index = 1;
  int count = 1;
  if (!part.empty()) {
    std::pair<absl::string_view, absl::string_view> kn = absl::StrSplit(part, '/');
    if (!absl::SimpleAtoi(kn.first, &index) || !absl::SimpleAtoi(kn.second, &count) || count < 1 ||
        count > 1 << 16 || index < 1 || index > count) {
      *error = absl::StrCat(kNatsPartHeader, " \"", part, "\": expected k/n with 1 <= k <= n");
      return Result::kBad;
    }
  }
  // A frame is counted once, however many of its parts are skipped.
  auto abandon = [this](uint64_t frame) {
    if (!abandoned_any_ || frame != last_abandoned_) ++abandoned_;
    abandoned_any_ = true;
    last_abandoned_ = frame;
  };
  if (next_ != 0 && (sequence != sequence_ || index != next_ || count != count_)) {
    abandon(sequence_);  // the rest of the frame being joined never came
    next_ = 0;
  }
  if (next_ == 0) {
    if (index != 1) {
      abandon(sequence);  // begun before this consumer, or its first parts lost
      return Result::kIncomplete;
    }
    sequence_ = sequence;
    count_ = count;
    bytes_.clear();
  }
  bytes_.append(data.data(), data.size());
  next_ = index + 1;
  if (index < count) return Result::kIncomplete;
  next_ = 0;
  if (!frame->ParseFromString(bytes_)) {
    *error = absl::StrCat("frame ", sequence, ": ", bytes_.size(), " bytes in ", count,
                          " parts are not a transient.v1.Frame");
    bytes_.clear();
    return Result::kBad;
  }
  bytes_.clear();
  return Result::kFrame;
}

}  // namespace transient::wire
