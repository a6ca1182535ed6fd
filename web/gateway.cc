// The web gateway: Boost.Beast (HTTP and WebSocket on Boost.Asio, header-only in Debian's
// libboost-dev 1.74) on one I/O thread; the daemon's frame stream, its stats and the pages'
// calls on threads of their own, which hand their results to the I/O thread (net::post).
#include "transient/web/gateway.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "transient/v1/transient.pb.h"
#include "transient/web/frame_message.h"
#include "transient/web/page_request.h"
#include "transient/wire/address.h"
#include "transient/wire/credentials.h"

namespace transient::web {
namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;

constexpr auto kHttpTimeout = std::chrono::seconds(30);
// Replies and news a page has not taken yet; a page that lets more pile up is closed.
constexpr size_t kMaxQueuedTexts = 256;
// Calls waiting for a worker; more are refused with ResourceExhausted.
constexpr size_t kMaxQueuedCalls = 64;

std::string ContentType(const std::string& name) {
  if (absl::EndsWith(name, ".html")) return "text/html; charset=utf-8";
  if (absl::EndsWith(name, ".js") || absl::EndsWith(name, ".mjs")) {
    return "text/javascript; charset=utf-8";
  }
  if (absl::EndsWith(name, ".css")) return "text/css; charset=utf-8";
  if (absl::EndsWith(name, ".json")) return "application/json";
  if (absl::EndsWith(name, ".svg")) return "image/svg+xml";
  if (absl::EndsWith(name, ".png")) return "image/png";
  return "application/octet-stream";
}

// A key of 128 random bits in hex: the page's URL carries it, its WebSocket must present it.
std::string NewPageKey() {
  std::random_device random;  // /dev/urandom
  std::string key;
  for (int i = 0; i < 4; ++i) absl::StrAppend(&key, absl::Hex(random(), absl::kZeroPad8));
  return key;
}

// The value of `name` in the query of `target` ("/ws?key=abc"), or "".
std::string QueryValue(const std::string& target, const std::string& name) {
  const size_t query = target.find('?');
  if (query == std::string::npos) return "";
  for (const absl::string_view part : absl::StrSplit(target.substr(query + 1), '&')) {
    if (absl::StartsWith(part, name + "=")) return std::string(part.substr(name.size() + 1));
  }
  return "";
}

bool PlainName(const std::string& name) {
  return !name.empty() && name.front() != '.' && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_';
  });
}

class PageSession;

// What the threads share. Everything about pages lives on the I/O thread.
class Gateway {
 public:
  Gateway(const GatewayOptions& options, std::map<std::string, std::string> files)
      : options_(options), files_(std::move(files)), key_(NewPageKey()) {}

  const std::string& key() const { return key_; }
  const GatewayOptions& options() const { return options_; }
  net::io_context& io() { return io_; }
  const std::map<std::string, std::string>& files() const { return files_; }
  uint16_t port() const { return port_; }
  void set_port(uint16_t port) { port_ = port; }

  void Log(const std::string& line) const {
    if (options_.log) options_.log(line);
  }

  // I/O thread.
  void AddPage(const std::shared_ptr<PageSession>& page);
  void RemovePage(PageSession* page);
  void BroadcastFrame(std::shared_ptr<const std::string> frame);
  void BroadcastText(const std::string& text);
  void BroadcastStats(const std::string& stats_json);
  const std::string& latest_info() const { return latest_info_; }
  const std::string& latest_daemon() const { return latest_daemon_; }
  void set_latest_info(std::string text) { latest_info_ = std::move(text); }
  void set_latest_daemon(std::string text) { latest_daemon_ = std::move(text); }

  // Any thread.
  std::shared_ptr<const client::Client> daemon() const {
    std::lock_guard<std::mutex> lock(daemon_mu_);
    return daemon_;
  }
  void set_daemon(std::shared_ptr<const client::Client> daemon) {
    std::lock_guard<std::mutex> lock(daemon_mu_);
    daemon_ = std::move(daemon);
  }

  // Turns true when the gateway stops: a calibration running for a page is cancelled then.
  const std::atomic<bool>* stopping() const { return &stopping_; }
  void Stop() { stopping_.store(true); }

  // Queues a page's call for the workers; false when the queue is full.
  bool QueueCall(std::function<void()> call) {
    std::lock_guard<std::mutex> lock(calls_mu_);
    if (calls_.size() >= kMaxQueuedCalls) return false;
    calls_.push_back(std::move(call));
    calls_cv_.notify_one();
    return true;
  }
  void Worker() {
    const std::atomic<bool>* stop = &stopping_;
    while (true) {
      std::function<void()> call;
      {
        std::unique_lock<std::mutex> lock(calls_mu_);
        calls_cv_.wait_for(lock, std::chrono::milliseconds(100),
                           [&] { return !calls_.empty() || stop->load(); });
        if (stop->load()) return;
        if (calls_.empty()) continue;
        call = std::move(calls_.front());
        calls_.pop_front();
      }
      call();
    }
  }

 private:
  const GatewayOptions& options_;
  const std::map<std::string, std::string> files_;
  const std::string key_;
  std::atomic<bool> stopping_{false};
  net::io_context io_{1};
  uint16_t port_ = 0;
  std::set<std::shared_ptr<PageSession>> pages_;
  std::string latest_info_, latest_daemon_;

  mutable std::mutex daemon_mu_;
  std::shared_ptr<const client::Client> daemon_;

  std::mutex calls_mu_;
  std::condition_variable calls_cv_;
  std::deque<std::function<void()>> calls_;
};

// One page's WebSocket: the newest frame and its texts go out one message at a time.
class PageSession : public std::enable_shared_from_this<PageSession> {
 public:
  PageSession(tcp::socket socket, Gateway& gateway) : ws_(std::move(socket)), gateway_(gateway) {}

  void Start(http::request<http::string_body> request) {
    ws_.read_message_max(kMaxPageRequestBytes);
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.async_accept(request, [self = shared_from_this()](beast::error_code error) {
      if (error) return;
      self->gateway_.AddPage(self);
      if (!self->gateway_.latest_daemon().empty()) self->SendText(self->gateway_.latest_daemon());
      if (!self->gateway_.latest_info().empty()) self->SendText(self->gateway_.latest_info());
      self->Read();
    });
  }

  void OfferFrame(std::shared_ptr<const std::string> frame) {
    if (frame_ != nullptr) ++dropped_;  // the older one was never sent
    frame_ = std::move(frame);
    Write();
  }

  void SendText(std::string text) {
    if (texts_.size() >= kMaxQueuedTexts) {
      Close();  // it reads nothing: it goes, the others stay
      return;
    }
    texts_.push_back(std::move(text));
    Write();
  }

  uint64_t sent() const { return sent_; }
  uint64_t dropped() const { return dropped_; }

  void Close() {
    if (closed_) return;
    closed_ = true;
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    gateway_.RemovePage(this);
  }

 private:
  void Read() {
    ws_.async_read(in_, [self = shared_from_this()](beast::error_code error, size_t) {
      if (error) {
        self->Close();
        return;
      }
      std::string text = beast::buffers_to_string(self->in_.data());
      self->in_.consume(self->in_.size());
      if (self->ws_.got_binary()) {
        self->SendText(ReplyError(
            0, absl::InvalidArgumentError("requests are text messages of JSON, not binary")));
      } else {
        self->OnRequest(text);
      }
      self->Read();
    });
  }

  void OnRequest(const std::string& text) {
    uint64_t id = 0;
    absl::StatusOr<PageRequest> request = ParsePageRequest(text, &id);
    if (!request.ok()) {
      SendText(ReplyError(id, request.status()));
      return;
    }
    auto shared = std::make_shared<PageRequest>(*std::move(request));
    std::weak_ptr<PageSession> weak = weak_from_this();
    Gateway& gateway = gateway_;
    auto reply = [&gateway, weak](std::string text) {
      net::post(gateway.io(), [weak, text = std::move(text)]() mutable {
        if (auto page = weak.lock()) page->SendText(std::move(text));
      });
    };
    const bool queued = gateway_.QueueCall([&gateway, shared, reply] {
      std::shared_ptr<const client::Client> daemon = gateway.daemon();
      if (daemon == nullptr) {
        reply(ReplyError(shared->id, absl::UnavailableError("the gateway has no daemon now")));
        return;
      }
      absl::StatusOr<std::unique_ptr<google::protobuf::Message>> result = Execute(
          *daemon, *shared,
          [&](int done, int total) { reply(ReplyProgress(shared->id, done, total)); },
          gateway.stopping());
      reply(result.ok() ? ReplyResult(shared->id, **result)
                        : ReplyError(shared->id, result.status()));
    });
    if (!queued) {
      SendText(
          ReplyError(id, absl::ResourceExhaustedError(absl::StrCat(
                             "more than ", kMaxQueuedCalls, " calls are waiting; try again"))));
    }
  }

  void Write() {
    if (writing_ || closed_) return;
    if (!texts_.empty()) {
      out_text_ = std::move(texts_.front());
      texts_.pop_front();
      writing_ = true;
      ws_.text(true);
      ws_.async_write(
          net::buffer(out_text_),
          [self = shared_from_this()](beast::error_code error, size_t) { self->OnWritten(error); });
      return;
    }
    if (frame_ != nullptr) {
      out_frame_ = std::move(frame_);
      frame_ = nullptr;
      writing_ = true;
      ws_.binary(true);
      ws_.async_write(net::buffer(*out_frame_),
                      [self = shared_from_this()](beast::error_code error, size_t) {
                        ++self->sent_;
                        self->out_frame_ = nullptr;
                        self->OnWritten(error);
                      });
    }
  }

  void OnWritten(beast::error_code error) {
    writing_ = false;
    if (error) {
      Close();
      return;
    }
    Write();
  }

  websocket::stream<beast::tcp_stream> ws_;
  Gateway& gateway_;
  beast::flat_buffer in_;
  std::deque<std::string> texts_;
  std::shared_ptr<const std::string> frame_;  // newest, not sent yet
  std::string out_text_;
  std::shared_ptr<const std::string> out_frame_;
  bool writing_ = false;
  bool closed_ = false;
  uint64_t sent_ = 0;
  uint64_t dropped_ = 0;
};

void Gateway::AddPage(const std::shared_ptr<PageSession>& page) {
  pages_.insert(page);
  Log(absl::StrCat("web: a page connected (", pages_.size(), " now)"));
}

void Gateway::RemovePage(PageSession* page) {
  for (auto it = pages_.begin(); it != pages_.end(); ++it) {
    if (it->get() == page) {
      pages_.erase(it);
      Log(absl::StrCat("web: a page left (", pages_.size(), " now)"));
      return;
    }
  }
}

void Gateway::BroadcastFrame(std::shared_ptr<const std::string> frame) {
  for (const auto& page : std::vector(pages_.begin(), pages_.end())) page->OfferFrame(frame);
}

void Gateway::BroadcastText(const std::string& text) {
  for (const auto& page : std::vector(pages_.begin(), pages_.end())) page->SendText(text);
}

void Gateway::BroadcastStats(const std::string& stats_json) {
  for (const auto& page : std::vector(pages_.begin(), pages_.end())) {
    page->SendText(absl::StrCat("{\"news\":\"stats\",\"body\":", stats_json,
                                ",\"gateway\":{\"sent\":", page->sent(),
                                ",\"dropped\":", page->dropped(), "}}"));
  }
}

// A plain HTTP exchange, or the upgrade to a page's WebSocket.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, Gateway& gateway)
      : stream_(std::move(socket)), gateway_(gateway) {}

  void Start() {
    parser_.emplace();
    parser_->header_limit(16 * 1024);
    parser_->body_limit(16 * 1024);
    stream_.expires_after(kHttpTimeout);
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](beast::error_code error, size_t) {
                       if (!error) self->OnRequest();
                     });
  }

 private:
  // Whether `host` (the Host header) names this gateway: a loopback name with our port.
  bool OurHost(const std::string& host) const {
    const std::string port = absl::StrCat(":", gateway_.port());
    return host == absl::StrCat("127.0.0.1", port) || host == absl::StrCat("localhost", port) ||
           host == absl::StrCat("[::1]", port);
  }

  void OnRequest() {
    http::request<http::string_body> request = parser_->release();
    const std::string host(request[http::field::host]);
    if (!OurHost(host)) {
      Respond(request, http::status::forbidden, "text/plain",
              "The web gateway answers only requests for its own address (Host " + host +
                  "): open it as http://127.0.0.1:" + std::to_string(gateway_.port()) + "/\n");
      return;
    }
    if (request.method() != http::verb::get) {
      Respond(request, http::status::method_not_allowed, "text/plain", "GET only\n");
      return;
    }
    std::string target(request.target());
    const std::string key = QueryValue(target, "key");
    if (const size_t query = target.find('?'); query != std::string::npos) target.resize(query);
    if (websocket::is_upgrade(request)) {
      const std::string origin(request[http::field::origin]);
      if (target != "/ws" || origin != "http://" + host) {
        Respond(request, http::status::forbidden, "text/plain",
                "WebSocket only at /ws, from the gateway's own page\n");
        return;
      }
      // Other users of this machine reach the port too: only who has the printed URL may use
      // the daemon through it.
      if (!wire::TokensEqual(key, gateway_.key())) {
        Respond(request, http::status::forbidden, "text/plain",
                "the page's key is missing or wrong: open the URL transient web printed\n");
        return;
      }
      stream_.expires_never();
      std::make_shared<PageSession>(stream_.release_socket(), gateway_)->Start(std::move(request));
      return;
    }
    if (target == "/") target = "/index.html";
    if (target == "/colormap.json") {
      Respond(request, http::status::ok, "application/json", gateway_.options().colour_map_json);
      return;
    }
    const std::string name = target.substr(1);
    const auto file = gateway_.files().find(name);
    if (target.front() != '/' || file == gateway_.files().end()) {
      Respond(request, http::status::not_found, "text/plain", "not found\n");
      return;
    }
    Respond(request, http::status::ok, ContentType(name), file->second);
  }

  void Respond(const http::request<http::string_body>& request, http::status status,
               const std::string& type, std::string body) {
    auto response = std::make_shared<http::response<http::string_body>>(status, request.version(),
                                                                        std::move(body));
    response->set(http::field::server, "transient web");
    response->set(http::field::content_type, type);
    response->set(http::field::cache_control, "no-cache");
    response->set("X-Content-Type-Options", "nosniff");
    response->keep_alive(false);
    response->prepare_payload();
    http::async_write(stream_, *response,
                      [self = shared_from_this(), response](beast::error_code, size_t) {
                        beast::error_code ignored;
                        self->stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
                      });
  }

  beast::tcp_stream stream_;
  Gateway& gateway_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

void Accept(tcp::acceptor& acceptor, Gateway& gateway) {
  acceptor.async_accept([&acceptor, &gateway](beast::error_code error, tcp::socket socket) {
    if (error == net::error::operation_aborted) return;
    if (!error) std::make_shared<HttpSession>(std::move(socket), gateway)->Start();
    Accept(acceptor, gateway);
  });
}

void Post(Gateway& gateway, std::function<void()> work) {
  net::post(gateway.io(), std::move(work));
}

void SleepUnlessStopped(const std::atomic<bool>* stop, std::chrono::milliseconds duration) {
  const auto until = std::chrono::steady_clock::now() + duration;
  while (!stop->load() && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

// Connects, streams frames to the pages, and reconnects with backoff when the daemon is lost.
void DaemonLoop(Gateway& gateway, const std::atomic<bool>* stop) {
  const GatewayOptions& options = gateway.options();
  auto backoff = std::chrono::milliseconds(250);
  std::string last_news;
  auto tell = [&](bool connected, const std::string& message) {
    std::string news = DaemonNews(connected, message);
    if (news == last_news) return;
    last_news = news;
    gateway.Log(absl::StrCat("web: daemon ", connected ? "connected: " : "lost: ", message));
    Post(gateway, [&gateway, news] {
      gateway.set_latest_daemon(news);
      gateway.BroadcastText(news);
    });
  };
  while (!stop->load()) {
    client::ConnectOptions connect = options.daemon;
    connect.cancel = stop;
    connect.timeout_s = 2.0;
    absl::StatusOr<client::Client> connected = client::Client::Connect(connect);
    absl::StatusOr<v1::Info> info =
        connected.ok() ? connected->GetInfo() : absl::StatusOr<v1::Info>(connected.status());
    if (!info.ok()) {
      if (stop->load()) break;
      tell(false, std::string(info.status().message()));
      SleepUnlessStopped(stop, backoff);
      backoff = std::min(backoff * 2, std::chrono::milliseconds(4000));
      continue;
    }
    auto daemon = std::make_shared<const client::Client>(*std::move(connected));
    gateway.set_daemon(daemon);
    const std::string info_news = News("info", *info);
    Post(gateway, [&gateway, info_news] {
      gateway.set_latest_info(info_news);
      gateway.BroadcastText(info_news);
    });
    tell(true, absl::StrCat("transientd at ", options.daemon.address, ", ", info->source_uri()));
    v1::StreamRequest request;
    request.set_encoding(v1::FLOAT16);
    for (const v1::Product product : {v1::RANGE, v1::AMPLITUDE, v1::FLAGS, v1::SLICES}) {
      const auto& offered = info->products();
      if (std::find(offered.begin(), offered.end(), product) != offered.end()) {
        request.add_products(product);
      }
    }
    request.mutable_slices()->set_bins(options.slice_bins);
    request.set_queue_frames(2);
    std::unique_ptr<client::FrameStream> stream = daemon->StreamFrames(request, {.cancel = stop});
    client::StreamFrame frame;
    uint64_t missed = 0;  // on announcements too: carried to the next frame the pages see
    while (stream->Next(&frame)) {
      backoff = std::chrono::milliseconds(250);
      missed += frame.missed;
      if (frame.kind == client::StreamFrame::Kind::kImages) {
        frame.missed = missed;
        missed = 0;
        auto message = std::make_shared<const std::string>(EncodeFrameMessage(frame));
        Post(gateway, [&gateway, message] { gateway.BroadcastFrame(message); });
      } else if (frame.kind == client::StreamFrame::Kind::kAnnouncement) {
        const std::string news = absl::StrCat("{\"news\":\"state\",\"body\":{\"state\":\"",
                                              v1::SourceState_Name(frame.state), "\"}}");
        Post(gateway, [&gateway, news] { gateway.BroadcastText(news); });
      }
    }
    const absl::Status finished = stream->Finish();
    gateway.set_daemon(nullptr);
    if (stop->load()) break;
    tell(false, finished.ok() ? "the stream ended" : std::string(finished.message()));
    SleepUnlessStopped(stop, backoff);
    backoff = std::min(backoff * 2, std::chrono::milliseconds(4000));
  }
}

// GetStats every second, to every page with its own counts.
void StatsLoop(Gateway& gateway, const std::atomic<bool>* stop) {
  while (!stop->load()) {
    SleepUnlessStopped(stop, std::chrono::milliseconds(1000));
    std::shared_ptr<const client::Client> daemon = gateway.daemon();
    if (daemon == nullptr) continue;
    absl::StatusOr<v1::Stats> stats = daemon->GetStats();
    if (!stats.ok()) continue;
    std::string json = MessageJson(*stats);
    Post(gateway, [&gateway, json] { gateway.BroadcastStats(json); });
  }
}

absl::StatusOr<std::map<std::string, std::string>> ReadStaticFiles(const std::string& dir) {
  std::map<std::string, std::string> files;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(dir, error)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file() || !PlainName(name)) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    std::ostringstream content;
    content << in.rdbuf();
    files[name] = content.str();
  }
  if (error) {
    return absl::InvalidArgumentError(
        absl::StrCat("the page's directory ", dir, " cannot be read: ", error.message()));
  }
  if (files.count("index.html") == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("the page's directory ", dir, " has no index.html"));
  }
  return files;
}

absl::StatusOr<tcp::endpoint> ListenEndpoint(const std::string& listen) {
  if (!wire::IsLoopback(listen) || absl::StartsWith(listen, "unix")) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--listen ", listen,
        ": the web gateway serves this machine only (127.0.0.1:PORT, localhost:PORT or "
        "[::1]:PORT); from another machine, forward the port (ssh -L 8080:127.0.0.1:8080 HOST)"));
  }
  const size_t colon = listen.rfind(':');
  std::string host = listen.substr(0, colon);
  int port = -1;
  if (colon == std::string::npos || !absl::SimpleAtoi(listen.substr(colon + 1), &port) ||
      port < 0 || port > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("--listen ", listen, ": expected host:port with a port 0..65535"));
  }
  if (host == "localhost") host = "127.0.0.1";
  if (host.size() >= 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
  beast::error_code error;
  const net::ip::address address = net::ip::make_address(host, error);
  if (error) {
    return absl::InvalidArgumentError(absl::StrCat("--listen ", listen, ": ", error.message()));
  }
  return tcp::endpoint(address, static_cast<uint16_t>(port));
}

}  // namespace

absl::Status RunGateway(const GatewayOptions& options, const std::atomic<bool>* stop) {
  absl::StatusOr<tcp::endpoint> endpoint = ListenEndpoint(options.listen);
  if (!endpoint.ok()) return endpoint.status();
  absl::StatusOr<std::map<std::string, std::string>> files = ReadStaticFiles(options.static_dir);
  if (!files.ok()) return files.status();
  Gateway gateway(options, *std::move(files));

  tcp::acceptor acceptor(gateway.io());
  beast::error_code error;
  acceptor.open(endpoint->protocol(), error);
  if (!error) acceptor.set_option(net::socket_base::reuse_address(true), error);
  if (!error) acceptor.bind(*endpoint, error);
  if (!error) acceptor.listen(net::socket_base::max_listen_connections, error);
  if (error) {
    return absl::UnavailableError(
        absl::StrCat("cannot listen on ", options.listen, ": ", error.message()));
  }
  gateway.set_port(acceptor.local_endpoint().port());
  gateway.Log(absl::StrCat("web: the viewer is at http://127.0.0.1:", gateway.port(),
                           "/?key=", gateway.key()));
  if (!options.url_file.empty()) {
    // Readable by this user only: it holds the key.
    const std::string url =
        absl::StrCat("http://127.0.0.1:", gateway.port(), "/?key=", gateway.key(), "\n");
    const int fd = ::open(options.url_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0 || ::fchmod(fd, 0600) != 0 ||
        ::write(fd, url.data(), url.size()) != static_cast<ssize_t>(url.size())) {
      if (fd >= 0) ::close(fd);
      return absl::InvalidArgumentError(
          absl::StrCat("--url-file ", options.url_file, " cannot be written"));
    }
    ::close(fd);
  }
  // The port file last: when it is there, so is the URL file.
  if (!options.port_file.empty()) {
    std::ofstream(options.port_file) << gateway.port() << "\n";
  }
  Accept(acceptor, gateway);

  std::thread threads[] = {
      std::thread([&] { DaemonLoop(gateway, gateway.stopping()); }),
      std::thread([&] { StatsLoop(gateway, gateway.stopping()); }),
      std::thread([&] { gateway.Worker(); }),
      std::thread([&] { gateway.Worker(); }),
  };

  net::steady_timer watch(gateway.io());
  std::function<void()> check = [&] {
    if (stop != nullptr && stop->load()) {
      gateway.Stop();
      gateway.io().stop();
      return;
    }
    watch.expires_after(std::chrono::milliseconds(100));
    watch.async_wait([&](beast::error_code) { check(); });
  };
  check();
  gateway.io().run();
  gateway.Stop();
  for (std::thread& thread : threads) thread.join();
  return absl::OkStatus();
}

}  // namespace transient::web
