#include "transient/web/page_request.h"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <cmath>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "transient/v1/transient.pb.h"

namespace transient::web {
namespace {

namespace pb = ::google::protobuf;

// 2^53: ids above it do not survive a JavaScript number.
constexpr double kMaxId = 9007199254740992.0;

std::unique_ptr<pb::Message> NewRequest(const std::string& method) {
  if (method == "GetInfo") return std::make_unique<v1::GetInfoRequest>();
  if (method == "GetStats") return std::make_unique<v1::GetStatsRequest>();
  if (method == "GetConfig") return std::make_unique<v1::GetConfigRequest>();
  if (method == "SetConfig") return std::make_unique<v1::Config>();
  if (method == "GetPixel") return std::make_unique<v1::GetPixelRequest>();
  if (method == "StartRecording") return std::make_unique<v1::StartRecordingRequest>();
  if (method == "StopRecording") return std::make_unique<v1::StopRecordingRequest>();
  if (method == "Calibrate") return std::make_unique<v1::CalibrateRequest>();
  return nullptr;
}

template <typename T>
absl::StatusOr<std::unique_ptr<pb::Message>> Boxed(absl::StatusOr<T> result) {
  if (!result.ok()) return result.status();
  return std::unique_ptr<pb::Message>(std::make_unique<T>(*std::move(result)));
}

// Whether `text` is UTF-8 (RFC 3629): no stray continuation bytes, overlong forms, surrogates
// or code points above U+10FFFF. Replies quote requests, and a WebSocket text message that is
// not UTF-8 makes the browser drop the connection.
bool IsUtf8(std::string_view text) {
  size_t i = 0;
  while (i < text.size()) {
    const auto byte = [&](size_t k) { return static_cast<uint8_t>(text[k]); };
    const uint8_t lead = byte(i);
    int length = 0;
    uint32_t code = 0, least = 0;
    if (lead < 0x80) {
      ++i;
      continue;
    } else if ((lead & 0xe0) == 0xc0) {
      length = 2, code = lead & 0x1f, least = 0x80;
    } else if ((lead & 0xf0) == 0xe0) {
      length = 3, code = lead & 0x0f, least = 0x800;
    } else if ((lead & 0xf8) == 0xf0) {
      length = 4, code = lead & 0x07, least = 0x10000;
    } else {
      return false;
    }
    if (i + length > text.size()) return false;
    for (int k = 1; k < length; ++k) {
      if ((byte(i + k) & 0xc0) != 0x80) return false;
      code = (code << 6) | (byte(i + k) & 0x3f);
    }
    if (code < least || code > 0x10ffff || (code >= 0xd800 && code <= 0xdfff)) return false;
    i += length;
  }
  return true;
}

}  // namespace

std::string MessageJson(const pb::Message& message) {
  pb::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;  // 0 and false shown, so the page reads them
  std::string json;
  if (!pb::util::MessageToJsonString(message, &json, options).ok()) return "{}";
  return json;
}

absl::StatusOr<PageRequest> ParsePageRequest(std::string_view text, uint64_t* id) {
  *id = 0;
  if (text.size() > kMaxPageRequestBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("a request of ", text.size(), " bytes; at most ", kMaxPageRequestBytes));
  }
  if (!IsUtf8(text)) return absl::InvalidArgumentError("a request must be UTF-8 text");
  pb::Struct object;
  if (const auto parsed = pb::util::JsonStringToMessage(std::string(text), &object); !parsed.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("a request must be a JSON object: ", std::string(parsed.message())));
  }
  const auto& fields = object.fields();
  PageRequest request;
  if (const auto it = fields.find("id"); it != fields.end()) {
    const double value = it->second.number_value();
    if (it->second.kind_case() != pb::Value::kNumberValue || !(value >= 1.0) || value >= kMaxId ||
        std::floor(value) != value) {
      return absl::InvalidArgumentError("id: a whole number >= 1 and < 2^53");
    }
    request.id = *id = static_cast<uint64_t>(value);
  } else {
    return absl::InvalidArgumentError("id: missing");
  }
  const auto method = fields.find("method");
  if (method == fields.end() || method->second.kind_case() != pb::Value::kStringValue) {
    return absl::InvalidArgumentError("method: missing, or not a string");
  }
  request.method = method->second.string_value();
  request.request = NewRequest(request.method);
  if (request.request == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("method: '", request.method,
                     "' is not one of GetInfo, GetStats, GetConfig, SetConfig, GetPixel, "
                     "StartRecording, StopRecording, Calibrate"));
  }
  for (const auto& [key, value] : fields) {
    if (key != "id" && key != "method" && key != "request") {
      return absl::InvalidArgumentError(absl::StrCat("'", key, "' is not a field of a request"));
    }
  }
  if (const auto body = fields.find("request"); body != fields.end()) {
    if (body->second.kind_case() != pb::Value::kStructValue) {
      return absl::InvalidArgumentError("request: not an object");
    }
    std::string json;
    if (!pb::util::MessageToJsonString(body->second.struct_value(), &json).ok()) {
      return absl::InvalidArgumentError("request: not JSON");
    }
    if (const auto parsed = pb::util::JsonStringToMessage(json, request.request.get());
        !parsed.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("request of ", request.method, ": ", std::string(parsed.message())));
    }
  }
  return request;
}

absl::StatusOr<std::unique_ptr<pb::Message>> Execute(
    const client::Client& daemon, const PageRequest& request,
    const std::function<void(int done, int total)>& on_progress, const std::atomic<bool>* cancel) {
  const std::string& m = request.method;
  const pb::Message& r = *request.request;
  if (m == "GetInfo") return Boxed(daemon.GetInfo());
  if (m == "GetStats") return Boxed(daemon.GetStats());
  if (m == "GetConfig") return Boxed(daemon.GetConfig());
  if (m == "SetConfig") return Boxed(daemon.SetConfig(static_cast<const v1::Config&>(r)));
  if (m == "GetPixel") {
    return Boxed(daemon.GetPixel(static_cast<const v1::GetPixelRequest&>(r)));
  }
  if (m == "StartRecording") {
    return Boxed(daemon.StartRecording(static_cast<const v1::StartRecordingRequest&>(r)));
  }
  if (m == "StopRecording") return Boxed(daemon.StopRecording());
  if (m == "Calibrate") {
    return Boxed(
        daemon.Calibrate(static_cast<const v1::CalibrateRequest&>(r), on_progress, cancel));
  }
  return absl::InvalidArgumentError(absl::StrCat("method: '", m, "' is unknown"));
}

std::string ReplyResult(uint64_t id, const pb::Message& result) {
  return absl::StrCat("{\"id\":", id, ",\"ok\":true,\"result\":", MessageJson(result), "}");
}

std::string ReplyError(uint64_t id, const absl::Status& status) {
  pb::Struct error;
  (*error.mutable_fields())["code"].set_string_value(absl::StatusCodeToString(status.code()));
  (*error.mutable_fields())["message"].set_string_value(std::string(status.message()));
  return absl::StrCat("{\"id\":", id, ",\"ok\":false,\"error\":", MessageJson(error), "}");
}

std::string ReplyProgress(uint64_t id, int done, int total) {
  return absl::StrCat("{\"id\":", id, ",\"progress\":{\"done\":", done, ",\"total\":", total, "}}");
}

std::string News(std::string_view kind, const pb::Message& body) {
  return absl::StrCat("{\"news\":\"", std::string(kind), "\",\"body\":", MessageJson(body), "}");
}

std::string DaemonNews(bool connected, std::string_view message) {
  pb::Struct body;
  (*body.mutable_fields())["connected"].set_bool_value(connected);
  (*body.mutable_fields())["message"].set_string_value(std::string(message));
  return News("daemon", body);
}

}  // namespace transient::web
