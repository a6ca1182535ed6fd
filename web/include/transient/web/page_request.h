// What the viewer page asks of transientd through the gateway, and what it is told (docs/web.md
// "Messages"): text WebSocket messages of JSON, the requests and results in protobuf's JSON
// mapping of transient.v1 (field names in lowerCamelCase, enums by name).
//
//   page -> gateway  {"id": 7, "method": "SetConfig", "request": {"threshold": 0.2}}
//   gateway -> page  {"id": 7, "ok": true, "result": {...transient.v1.Config...}}
//                    {"id": 7, "ok": false, "error": {"code": "INVALID_ARGUMENT",
//                                                     "message": "...the daemon's words..."}}
//                    {"id": 7, "progress": {"done": 3, "total": 20}}     (Calibrate)
//                    {"news": "stats", "body": {...transient.v1.Stats...}}  (every second)
//                    {"news": "info", "body": {...transient.v1.Info...}}    (on connecting)
//                    {"news": "daemon", "body": {"connected": false, "message": "..."}}
#pragma once

#include <google/protobuf/message.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/client/client.h"

namespace transient::web {

// Text messages from a page longer than this are refused (the WebSocket's read limit).
inline constexpr size_t kMaxPageRequestBytes = 64 * 1024;

struct PageRequest {
  uint64_t id = 0;
  std::string method;  // GetInfo, GetStats, GetConfig, SetConfig, GetPixel, StartRecording,
                       // StopRecording, Calibrate
  std::unique_ptr<google::protobuf::Message> request;  // of the method's request type
};

// InvalidArgument naming what is wrong: not JSON, not an object, an id that is not a whole
// number in [1, 2^53), an unknown method, or a request that does not parse as the method's
// request message (unknown fields included). The id of a request that has one is kept in
// *id even when the rest fails, so that the refusal reaches the right caller.
absl::StatusOr<PageRequest> ParsePageRequest(std::string_view text, uint64_t* id);

// Calls the daemon. Calibrate reports on_progress(done, total) per take; *cancel (may be null)
// stops it.
absl::StatusOr<std::unique_ptr<google::protobuf::Message>> Execute(
    const client::Client& daemon, const PageRequest& request,
    const std::function<void(int done, int total)>& on_progress, const std::atomic<bool>* cancel);

// `message` in protobuf's JSON mapping, every field shown ("{}" if it cannot be printed).
std::string MessageJson(const google::protobuf::Message& message);

// The texts above.
std::string ReplyResult(uint64_t id, const google::protobuf::Message& result);
std::string ReplyError(uint64_t id, const absl::Status& status);
std::string ReplyProgress(uint64_t id, int done, int total);
std::string News(std::string_view kind, const google::protobuf::Message& body);
std::string DaemonNews(bool connected, std::string_view message);

}  // namespace transient::web
