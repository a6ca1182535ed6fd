// The web gateway's page requests (web/page_request.h): any text a page sends through
// ParsePageRequest. Properties: an accepted request has an id >= 1, a method and its request
// message; the refusal of any other is JSON that protobuf reads back, with the id kept.
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <cstdint>
#include <cstdlib>
#include <string>

#include "transient/web/page_request.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  uint64_t id = 0;
  absl::StatusOr<transient::web::PageRequest> request = transient::web::ParsePageRequest(text, &id);
  if (request.ok()) {
    if (request->id == 0 || request->id != id || request->request == nullptr ||
        request->method.empty()) {
      std::abort();
    }
    return 0;
  }
  google::protobuf::Struct reply;
  if (!google::protobuf::util::JsonStringToMessage(transient::web::ReplyError(id, request.status()),
                                                   &reply)
           .ok() ||
      reply.fields().at("id").number_value() != static_cast<double>(id)) {
    std::abort();
  }
  return 0;
}
