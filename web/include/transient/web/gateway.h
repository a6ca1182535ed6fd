// The web gateway (`transient web`, docs/web.md): a client of transientd that serves the viewer
// page over HTTP and its live frames and calls over a WebSocket, on this machine only.
//
// HTTP GET: "/" the page, "/<file>" the other files of the static directory (read once at
// start, served from memory: no path from a request reaches the file system),
// "/colormap.json" the colour map the page draws with; "/ws" upgrades to the WebSocket.
// Requests whose Host is not this machine's address and port (DNS rebinding), WebSocket
// upgrades from another origin (another site in the same browser) or without the page's key
// (128 random bits made at start, in the URL printed: other users of the machine reach the
// port too), and anything but GET are refused.
//
// Frames (frame_message.h) go to each page as fast as it takes them: a page that is still
// receiving one when the next arrives has the older unsent one replaced (counted as dropped
// and reported to it every second), never queued. Calls (page_request.h) run on two worker
// threads. A lost daemon is reported to every page ("daemon" news) and reconnected with
// backoff; pages that lose the gateway reconnect by themselves (the page's own code).
#pragma once

#include <atomic>
#include <functional>
#include <string>

#include "absl/status/status.h"
#include "transient/client/client.h"

namespace transient::web {

struct GatewayOptions {
  client::ConnectOptions daemon;          // where transientd is and how to reach it
  std::string listen = "127.0.0.1:8080";  // host:port on this machine (wire::IsLoopback)
  std::string port_file = {};             // the port actually bound is written here
  std::string url_file = {};              // the page's URL with its key is written here
  std::string static_dir;                 // index.html and the files it loads
  std::string colour_map_json;            // served as /colormap.json
  uint32_t slice_bins = 32;               // slices over one period streamed for the video
  // One line per event (daemon connected or lost, pages coming and going); may be empty.
  std::function<void(const std::string&)> log = {};
};

// Serves until *stop turns true (checked every 100 ms), then closes every page and returns OK.
// InvalidArgument for a listening address that is not this machine's or does not parse, a
// static directory without index.html; Unavailable when the address cannot be bound.
absl::Status RunGateway(const GatewayOptions& options, const std::atomic<bool>* stop);

}  // namespace transient::web
