// A Foxglove WebSocket protocol server (subprotocol foxglove.websocket.v1, spec: github.com/foxglove/ws-protocol
// docs/spec.md) on Boost.Beast. No DDS: the bridge (bridge.hpp) adds channels and publishes payloads.
//
//   bridge::FoxgloveServer server({.address = "127.0.0.1", .port = 8765});   // throws ServerError if taken
//   auto id = server.addChannel({.topic = "perception/obstacles", .encoding = "cdr", .schema_name = "ddsnav::msg::ObstacleArray",
//                                .schema = idl_text, .schema_encoding = "omgidl", .latched = true});
//   server.publish(id, stamp_ns, payload);   // any thread, never blocks on a client
//   server.removeChannel(id);
//
// Implemented: serverInfo, status, advertise/unadvertise, subscribe/unsubscribe, binary Message Data.
// Not offered (no capability announced): client publish, parameters, services, time, assets.
//
// Each client has its own send queue. Control messages (serverInfo, advertise, status) are always kept;
// message data beyond the queue's limits drops the oldest queued data first (newest data wins), counted
// per client and reported to that client by a warning status at most once a second. Bad client input
// (malformed JSON, unknown op, unknown channel, a binary frame, too many subscriptions) gets an error
// status to that client only (at most 50 a second, then one count of the rest). A client whose control
// queue overflows (it floods and never reads) is disconnected.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace ddsnav::bridge {

class ServerError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

struct ServerOptions {
  std::string address = "127.0.0.1";  // another interface only when asked
  std::uint16_t port = 8765;          // 0: any free port (tests); see FoxgloveServer::port()
  std::string name = "ddsnav bridge";
  std::size_t max_queue_bytes = 32u << 20;     // message data waiting for one client
  std::size_t max_queue_messages = 2000;
  std::size_t max_control_messages = 10000;    // queued control messages before the client is dropped
  std::size_t max_subscriptions = 1024;        // per client
  std::size_t max_incoming_bytes = 1u << 20;   // largest client message accepted
};

struct ChannelSpec {
  std::string topic;
  std::string encoding;         // "cdr" | "json"
  std::string schema_name;      // "ddsnav::msg::Path" | "foxglove.SceneUpdate"
  std::string schema;           // IDL text | JSON Schema text
  std::string schema_encoding;  // "omgidl" | "jsonschema"
  bool latched = false;         // the newest message goes to each new subscriber (state topics)
};

struct ClientStats {
  std::string remote;  // address:port
  std::uint64_t sent = 0;      // message data frames written
  std::uint64_t dropped = 0;   // message data frames dropped for this client
  std::size_t subscriptions = 0;
  std::size_t queued_bytes = 0;
};

struct ServerStats {
  std::uint64_t published = 0;  // publish() calls
  std::vector<ClientStats> clients;
};

class FoxgloveServer {
 public:
  // Binds and starts serving on its own thread. Throws ServerError naming address:port when it cannot.
  explicit FoxgloveServer(ServerOptions options);
  ~FoxgloveServer();  // closes every client and stops the thread
  FoxgloveServer(const FoxgloveServer&) = delete;
  FoxgloveServer& operator=(const FoxgloveServer&) = delete;

  std::uint16_t port() const;  // the bound port

  // Advertised to every connected client and to clients that connect later. Thread-safe.
  std::uint32_t addChannel(ChannelSpec spec);
  void removeChannel(std::uint32_t channel_id);
  // Sends payload to the channel's subscribers (shared, not copied per client). Thread-safe, non-blocking.
  void publish(std::uint32_t channel_id, std::uint64_t timestamp_ns, std::shared_ptr<const std::vector<std::uint8_t>> payload);
  void publish(std::uint32_t channel_id, std::uint64_t timestamp_ns, std::span<const std::uint8_t> payload);

  ServerStats stats() const;  // waits for the server thread briefly

  struct Impl;  // the server thread's state (server.cpp)

 private:
  std::shared_ptr<Impl> impl_;
};

}  // namespace ddsnav::bridge
