#include <ddsnav/bridge/server.hpp>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <array>
#include <atomic>
#include <chrono>
#include <deque>
#include <future>
#include <map>
#include <set>
#include <thread>

namespace ddsnav::bridge {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;
using Payload = std::shared_ptr<const std::vector<std::uint8_t>>;

constexpr std::uint8_t kMessageDataOpcode = 0x01;
enum StatusLevel { kInfo = 0, kWarning = 1, kError = 2 };

bool offersSubprotocol(std::string_view header) {
  // "a, b, c": a comma-separated token list.
  while (!header.empty()) {
    const auto comma = header.find(',');
    std::string_view token = header.substr(0, comma);
    while (!token.empty() && token.front() == ' ') token.remove_prefix(1);
    while (!token.empty() && token.back() == ' ') token.remove_suffix(1);
    if (token == kSubprotocol) return true;
    if (comma == std::string_view::npos) break;
    header.remove_prefix(comma + 1);
  }
  return false;
}

json channelJson(std::uint32_t id, const ChannelSpec& c) {
  return {{"id", id}, {"topic", c.topic}, {"encoding", c.encoding}, {"schemaName", c.schema_name},
          {"schema", c.schema}, {"schemaEncoding", c.schema_encoding}};
}

}  // namespace

struct Channel {
  ChannelSpec spec;
  Payload latest;
  std::uint64_t latest_time = 0;
};

class Session;

struct FoxgloveServer::Impl {
  ServerOptions options;
  net::io_context io;
  tcp::acceptor acceptor{io};
  net::steady_timer drop_timer{io};
  std::thread thread;
  std::atomic<std::uint32_t> next_channel{1};
  std::atomic<std::uint64_t> published{0};
  // Everything below: the server thread only.
  std::map<std::uint32_t, Channel> channels;
  std::set<std::shared_ptr<Session>> sessions;

  void accept();
  void reportDrops();
  void publishOnThread(std::uint32_t channel, std::uint64_t time, const Payload& payload);
};

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket socket, FoxgloveServer::Impl& server) : ws_(std::move(socket)), server_(server) {
    beast::error_code ec;
    const auto ep = ws_.next_layer().remote_endpoint(ec);
    remote_ = ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
  }

  void start() {
    http::async_read(ws_.next_layer(), read_buffer_, request_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onRequest(ec); });
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    beast::error_code ec;
    ws_.next_layer().shutdown(tcp::socket::shutdown_both, ec);
    ws_.next_layer().close(ec);
    server_.sessions.erase(shared_from_this());
  }

  // --- called by the server (its thread) ---
  void advertise(const std::vector<std::uint32_t>& ids) {
    json channels = json::array();
    for (auto id : ids)
      if (auto it = server_.channels.find(id); it != server_.channels.end()) channels.push_back(channelJson(id, it->second.spec));
    if (!channels.empty()) sendText(json{{"op", "advertise"}, {"channels", std::move(channels)}}.dump());
  }
  void unadvertise(std::uint32_t channel) {
    for (auto it = subscriptions_.begin(); it != subscriptions_.end();) it = it->second == channel ? subscriptions_.erase(it) : std::next(it);
    sendText(json{{"op", "unadvertise"}, {"channelIds", {channel}}}.dump());
  }
  void deliver(std::uint32_t channel, std::uint64_t time, const Payload& payload) {
    for (const auto& [sub, ch] : subscriptions_)
      if (ch == channel) sendData(sub, time, payload);
  }
  void status(int level, const std::string& message) {
    // A client flooding bad requests gets a bounded answer: the first errors of each second, then a count.
    if (level == kError && ++errors_this_second_ > kErrorsPerSecond) {
      ++suppressed_errors_;
      return;
    }
    sendText(json{{"op", "status"}, {"level", level}, {"message", message}}.dump());
  }
  // Once a second: errors held back, data dropped.
  void reportDrops() {
    if (suppressed_errors_ > 0) {
      sendText(json{{"op", "status"}, {"level", kError},
                    {"message", std::to_string(suppressed_errors_) + " more error(s) in the last second not reported one by one"}}.dump());
      suppressed_errors_ = 0;
    }
    errors_this_second_ = 0;
    if (dropped_ == reported_dropped_) return;
    const auto recent = dropped_ - reported_dropped_;
    reported_dropped_ = dropped_;
    status(kWarning, "dropped " + std::to_string(recent) + " message(s) since the last report (" + std::to_string(dropped_) +
                         " in all): this client reads slower than the data arrives; the oldest queued messages go first");
  }
  ClientStats stats() const { return {remote_, sent_, dropped_, subscriptions_.size(), queued_bytes_}; }
  bool accepted() const { return accepted_; }

 private:
  struct Outgoing {
    std::string text;  // control message (kept), or empty for message data
    std::array<std::uint8_t, 13> header{};
    Payload payload;
    bool isData() const { return payload != nullptr; }
  };

  void onRequest(beast::error_code ec) {
    if (ec) return close();
    const auto offered = request_[http::field::sec_websocket_protocol];
    if (!websocket::is_upgrade(request_) || !offersSubprotocol(std::string_view(offered.data(), offered.size()))) {
      http::response<http::string_body> res{http::status::bad_request, request_.version()};
      res.set(http::field::content_type, "text/plain");
      res.body() = std::string("ddsnav bridge: a WebSocket client offering the subprotocol ") + kSubprotocol + " is expected\n";
      res.prepare_payload();
      http::write(ws_.next_layer(), res, ec);
      return close();
    }
    ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& res) {
      res.set(http::field::sec_websocket_protocol, kSubprotocol);
      res.set(http::field::server, "ddsnav-bridge");
    }));
    ws_.read_message_max(server_.options.max_incoming_bytes);
    ws_.async_accept(request_, [self = shared_from_this()](beast::error_code ec) { self->onAccept(ec); });
  }

  void onAccept(beast::error_code ec) {
    if (ec) return close();
    accepted_ = true;
    read_buffer_.clear();
    sendText(json{{"op", "serverInfo"},
                  {"name", server_.options.name},
                  {"capabilities", json::array()},
                  {"supportedEncodings", json::array()},
                  {"metadata", json::object()},
                  {"sessionId", std::to_string(std::chrono::system_clock::now().time_since_epoch().count())}}
                 .dump());
    std::vector<std::uint32_t> ids;
    for (const auto& [id, c] : server_.channels) ids.push_back(id);
    advertise(ids);
    read();
  }

  void read() {
    ws_.async_read(read_buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onRead(ec); });
  }

  void onRead(beast::error_code ec) {
    if (ec) {
      if (ec == websocket::error::message_too_big) spdlog::warn("bridge: {} sent a message over {} bytes; closing", remote_, server_.options.max_incoming_bytes);
      return close();
    }
    if (ws_.got_binary()) {
      const auto data = read_buffer_.cdata();
      const int opcode = data.size() > 0 ? static_cast<const std::uint8_t*>(data.data())[0] : -1;
      status(kError, "binary message with opcode " + std::to_string(opcode) +
                         " refused: this server offers no client capabilities (clientPublish, services)");
    } else {
      handleText(beast::buffers_to_string(read_buffer_.cdata()));
    }
    read_buffer_.consume(read_buffer_.size());
    read();
  }

  void handleText(const std::string& text) {
    const json request = json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (request.is_discarded()) return status(kError, "malformed JSON message (" + std::to_string(text.size()) + " bytes)");
    if (!request.is_object() || !request.contains("op") || !request["op"].is_string())
      return status(kError, "a text message must be a JSON object with a string field \"op\"");
    const std::string op = request["op"];
    if (op == "subscribe") return subscribe(request);
    if (op == "unsubscribe") return unsubscribe(request);
    static const std::set<std::string> known = {"advertise", "unadvertise", "getParameters", "setParameters",
                                                "subscribeParameterUpdates", "unsubscribeParameterUpdates",
                                                "subscribeConnectionGraph", "unsubscribeConnectionGraph", "fetchAsset"};
    if (known.count(op)) return status(kError, "op \"" + op + "\" needs a capability this server does not offer");
    status(kError, "unknown op \"" + op.substr(0, 64) + "\"");
  }

  static bool isId(const json& v) { return v.is_number_unsigned() && v.get<std::uint64_t>() <= 0xffffffffu; }

  void subscribe(const json& request) {
    const auto it = request.find("subscriptions");
    if (it == request.end() || !it->is_array()) return status(kError, "subscribe: \"subscriptions\" must be an array");
    std::size_t refused = 0;
    std::string first_reason;
    auto refuse = [&](std::string why) {
      if (refused++ == 0) first_reason = std::move(why);
    };
    for (const auto& s : *it) {
      if (!s.is_object() || !s.contains("id") || !s.contains("channelId") || !isId(s["id"]) || !isId(s["channelId"])) {
        refuse("each subscription must be {\"id\": uint32, \"channelId\": uint32}");
        continue;
      }
      const std::uint32_t id = s["id"], channel = s["channelId"];
      const auto ch = server_.channels.find(channel);
      if (ch == server_.channels.end()) {
        refuse("unknown channel id " + std::to_string(channel));
      } else if (subscriptions_.count(id)) {
        refuse("subscription id " + std::to_string(id) + " is already in use");
      } else if (subscriptions_.size() >= server_.options.max_subscriptions) {
        refuse("more than " + std::to_string(server_.options.max_subscriptions) + " subscriptions");
      } else {
        subscriptions_.emplace(id, channel);
        if (ch->second.spec.latched && ch->second.latest) sendData(id, ch->second.latest_time, ch->second.latest);
      }
    }
    // One status per request, however many subscriptions it refused: a flood gets no flood back.
    if (refused > 0)
      status(kError, "subscribe: " + std::to_string(refused) + " of " + std::to_string(it->size()) + " refused; first: " + first_reason);
  }

  void unsubscribe(const json& request) {
    const auto it = request.find("subscriptionIds");
    if (it == request.end() || !it->is_array()) return status(kError, "unsubscribe: \"subscriptionIds\" must be an array");
    std::size_t unknown = 0;
    for (const auto& id : *it)
      if (!isId(id) || subscriptions_.erase(id.get<std::uint32_t>()) == 0) ++unknown;
    if (unknown > 0) status(kError, "unsubscribe: " + std::to_string(unknown) + " unknown subscription id(s)");
  }

  void sendText(std::string text) {
    if (closed_) return;
    if (++control_queued_ > server_.options.max_control_messages) {
      spdlog::warn("bridge: {} does not read its control messages ({} queued); disconnecting", remote_, control_queued_);
      return close();
    }
    Outgoing o;
    o.text = std::move(text);
    queue_.push_back(std::move(o));
    write();
  }

  void sendData(std::uint32_t subscription, std::uint64_t time, const Payload& payload) {
    if (closed_) return;
    Outgoing o;
    o.header[0] = kMessageDataOpcode;
    for (int i = 0; i < 4; ++i) o.header[1 + i] = static_cast<std::uint8_t>(subscription >> (8 * i));
    for (int i = 0; i < 8; ++i) o.header[5 + i] = static_cast<std::uint8_t>(time >> (8 * i));
    o.payload = payload;
    queued_bytes_ += payload->size();
    ++queued_data_;
    queue_.push_back(std::move(o));
    // Over the limits: drop the oldest data not being written (index 0 is in flight while writing).
    std::size_t i = writing_ ? 1 : 0;
    while ((queued_bytes_ > server_.options.max_queue_bytes || queued_data_ > server_.options.max_queue_messages) &&
           queued_data_ > 1 && i < queue_.size()) {
      if (!queue_[i].isData() || (i == queue_.size() - 1)) {
        ++i;
        continue;
      }
      queued_bytes_ -= queue_[i].payload->size();
      --queued_data_;
      ++dropped_;
      queue_.erase(queue_.begin() + static_cast<std::ptrdiff_t>(i));
    }
    write();
  }

  void write() {
    if (writing_ || queue_.empty() || !accepted_ || closed_) return;
    writing_ = true;
    const Outgoing& o = queue_.front();
    auto done = [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onWrite(ec); };
    if (o.isData()) {
      ws_.binary(true);
      ws_.async_write(std::array<net::const_buffer, 2>{net::buffer(o.header), net::buffer(*o.payload)}, std::move(done));
    } else {
      ws_.text(true);
      ws_.async_write(net::buffer(o.text), std::move(done));
    }
  }

  void onWrite(beast::error_code ec) {
    writing_ = false;
    if (ec) return close();
    Outgoing& o = queue_.front();
    if (o.isData()) {
      queued_bytes_ -= o.payload->size();
      --queued_data_;
      ++sent_;
    } else {
      --control_queued_;
    }
    queue_.pop_front();
    write();
  }

  websocket::stream<tcp::socket> ws_;
  FoxgloveServer::Impl& server_;
  std::string remote_;
  beast::flat_buffer read_buffer_;
  http::request<http::string_body> request_;
  std::map<std::uint32_t, std::uint32_t> subscriptions_;  // subscription id -> channel id
  std::deque<Outgoing> queue_;
  std::size_t queued_bytes_ = 0, queued_data_ = 0, control_queued_ = 0;
  std::uint64_t sent_ = 0, dropped_ = 0, reported_dropped_ = 0;
  static constexpr std::uint64_t kErrorsPerSecond = 50;
  std::uint64_t errors_this_second_ = 0, suppressed_errors_ = 0;
  bool writing_ = false, accepted_ = false, closed_ = false;
};

void FoxgloveServer::Impl::accept() {
  acceptor.async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (ec) {
      if (ec != net::error::operation_aborted) spdlog::warn("bridge: accept failed: {}", ec.message());
      if (!acceptor.is_open()) return;
    } else {
      socket.set_option(tcp::no_delay(true), ec);
      auto session = std::make_shared<Session>(std::move(socket), *this);
      sessions.insert(session);
      session->start();
    }
    accept();
  });
}

void FoxgloveServer::Impl::reportDrops() {
  drop_timer.expires_after(std::chrono::seconds(1));
  drop_timer.async_wait([this](beast::error_code ec) {
    if (ec) return;
    for (const auto& s : std::vector<std::shared_ptr<Session>>(sessions.begin(), sessions.end())) s->reportDrops();
    reportDrops();
  });
}

void FoxgloveServer::Impl::publishOnThread(std::uint32_t channel, std::uint64_t time, const Payload& payload) {
  const auto it = channels.find(channel);
  if (it == channels.end()) return;  // removed meanwhile
  if (it->second.spec.latched) {
    it->second.latest = payload;
    it->second.latest_time = time;
  }
  for (const auto& s : std::vector<std::shared_ptr<Session>>(sessions.begin(), sessions.end()))
    if (s->accepted()) s->deliver(channel, time, payload);
}

FoxgloveServer::FoxgloveServer(ServerOptions options) : impl_(std::make_shared<Impl>()) {
  impl_->options = std::move(options);
  const std::string where = impl_->options.address + ":" + std::to_string(impl_->options.port);
  beast::error_code ec;
  const auto address = net::ip::make_address(impl_->options.address, ec);
  if (ec) throw ServerError("'" + impl_->options.address + "' is not an IP address");
  const tcp::endpoint endpoint(address, impl_->options.port);
  auto& acceptor = impl_->acceptor;
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (ec == net::error::address_in_use)
    throw ServerError("cannot listen on " + where + ": the port is in use (another bridge? choose one with --port)");
  if (!ec) acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec) throw ServerError("cannot listen on " + where + ": " + ec.message());
  impl_->accept();
  impl_->reportDrops();
  impl_->thread = std::thread([impl = impl_] { impl->io.run(); });
}

FoxgloveServer::~FoxgloveServer() {
  net::post(impl_->io, [impl = impl_] {
    beast::error_code ec;
    impl->acceptor.close(ec);
    impl->drop_timer.cancel();
    for (const auto& s : std::vector<std::shared_ptr<Session>>(impl->sessions.begin(), impl->sessions.end())) s->close();
    impl->io.stop();
  });
  if (impl_->thread.joinable()) impl_->thread.join();
}

std::uint16_t FoxgloveServer::port() const {
  beast::error_code ec;
  return impl_->acceptor.local_endpoint(ec).port();
}

std::uint32_t FoxgloveServer::addChannel(ChannelSpec spec) {
  const std::uint32_t id = impl_->next_channel++;
  net::post(impl_->io, [impl = impl_, id, spec = std::move(spec)]() mutable {
    impl->channels.emplace(id, Channel{std::move(spec), nullptr, 0});
    for (const auto& s : std::vector<std::shared_ptr<Session>>(impl->sessions.begin(), impl->sessions.end()))
      if (s->accepted()) s->advertise({id});
  });
  return id;
}

void FoxgloveServer::removeChannel(std::uint32_t id) {
  net::post(impl_->io, [impl = impl_, id] {
    if (impl->channels.erase(id) == 0) return;
    for (const auto& s : std::vector<std::shared_ptr<Session>>(impl->sessions.begin(), impl->sessions.end()))
      if (s->accepted()) s->unadvertise(id);
  });
}

void FoxgloveServer::publish(std::uint32_t channel, std::uint64_t time, Payload payload) {
  ++impl_->published;
  net::post(impl_->io, [impl = impl_, channel, time, payload = std::move(payload)] { impl->publishOnThread(channel, time, payload); });
}

void FoxgloveServer::publish(std::uint32_t channel, std::uint64_t time, std::span<const std::uint8_t> payload) {
  publish(channel, time, std::make_shared<const std::vector<std::uint8_t>>(payload.begin(), payload.end()));
}

ServerStats FoxgloveServer::stats() const {
  auto promise = std::make_shared<std::promise<ServerStats>>();
  auto future = promise->get_future();
  net::post(impl_->io, [impl = impl_, promise] {
    ServerStats s;
    s.published = impl->published.load();
    for (const auto& session : impl->sessions)
      if (session->accepted()) s.clients.push_back(session->stats());
    promise->set_value(std::move(s));
  });
  if (future.wait_for(std::chrono::seconds(2)) != std::future_status::ready) return {impl_->published.load(), {}};
  return future.get();
}

}  // namespace ddsnav::bridge
