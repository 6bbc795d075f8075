// ddsnav bench-bridge: 1 MB clouds at 10 Hz from a publisher process through `Bridge` to WebSocket clients.
// Two clients read everything (raw sensors/points and its foxglove.PointCloud view); a third subscribes
// and then stops reading. Reports what the publisher sent, what the bridge took from the bus (loss on the
// bus side), what each client got, the raw end-to-end latency (cloud stamp -> client), and the drops the
// server counted for the stalled client. Results: docs/benchmarks/bridge.md.
#include <ddsnav/bridge/bridge.hpp>
#include <ddsnav/msg/messages.hpp>

#include <CLI/CLI.hpp>
#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>
#include <thread>

using namespace ddsnav;
namespace net = boost::asio;
namespace websocket = boost::beast::websocket;
using tcp = net::ip::tcp;

namespace {

std::int64_t nowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

int publisher(int domain, const std::string& dds, double mb, double hz, double seconds) {
  bus::Participant p({.vendor = bus::parseVendor(dds), .domain_id = domain, .name = "bench-bridge-publisher"});
  auto pub = p.publisher<msg::PointCloud>("sensors/points", bus::Qos::sensorData());
  msg::PointCloud cloud;
  cloud.header().frame_id("map");
  const std::size_t points = static_cast<std::size_t>(mb * 1e6 / 12);
  cloud.xyz().resize(3 * points);
  for (std::size_t i = 0; i < cloud.xyz().size(); ++i) cloud.xyz()[i] = static_cast<float>(i % 1000) * 0.01f;
  if (!pub.waitForSubscribers(1, std::chrono::seconds(20))) return 3;
  std::this_thread::sleep_for(std::chrono::seconds(1));  // the reader's side of discovery
  const auto period = std::chrono::duration<double>(1.0 / hz);
  const int count = static_cast<int>(hz * seconds);
  auto next = std::chrono::steady_clock::now();
  for (int i = 0; i < count; ++i) {
    cloud.header().stamp_ns(nowNs());
    pub.publish(cloud);
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    std::this_thread::sleep_until(next);
  }
  std::printf("%d\n", count);
  return 0;
}

struct Client {
  std::string name;
  bool reads = true;
  std::atomic<std::uint64_t> raw{0}, view{0}, bytes{0};
  std::atomic<std::uint16_t> local_port{0};  // to find this client in the server's statistics
  std::mutex mutex;                // latency_ms: written by the client thread, read by main
  std::vector<double> latency_ms;  // raw clouds
  std::thread thread;
};

void runClient(Client& c, std::uint16_t port, const std::atomic<bool>& stop) {
  net::io_context io;
  websocket::stream<tcp::socket> ws(io);
  ws.next_layer().connect({net::ip::make_address("127.0.0.1"), port});
  c.local_port = ws.next_layer().local_endpoint().port();
  ws.set_option(websocket::stream_base::decorator(
      [](websocket::request_type& req) { req.set(boost::beast::http::field::sec_websocket_protocol, bridge::kSubprotocol); }));
  ws.read_message_max(64u << 20);
  ws.handshake("127.0.0.1", "/");
  std::map<std::string, std::uint32_t> ids;
  std::map<std::uint32_t, std::string> subscribed;
  boost::beast::flat_buffer buffer;
  while (!stop) {
    // A client that stops reading: subscribed once, then idle with its socket open.
    if (!c.reads && subscribed.size() == 2) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    ws.read(buffer);
    const auto data = buffer.cdata();
    const auto* bytes = static_cast<const std::uint8_t*>(data.data());
    if (ws.got_text()) {
      const auto m = nlohmann::json::parse(boost::beast::buffers_to_string(data));
      if (m["op"] == "advertise")
        for (const auto& ch : m["channels"]) ids[ch["topic"]] = ch["id"];
      for (const char* topic : {"sensors/points", "foxglove/sensors/points"}) {
        if (!ids.count(topic) || std::any_of(subscribed.begin(), subscribed.end(), [&](auto& s) { return s.second == topic; })) continue;
        const std::uint32_t sub = static_cast<std::uint32_t>(subscribed.size() + 1);
        subscribed[sub] = topic;
        ws.text(true);
        ws.write(net::buffer(nlohmann::json{{"op", "subscribe"}, {"subscriptions", {{{"id", sub}, {"channelId", ids[topic]}}}}}.dump()));
      }
    } else if (data.size() >= 13 && bytes[0] == 1) {
      std::uint32_t sub;
      std::memcpy(&sub, bytes + 1, 4);
      c.bytes += data.size();
      if (subscribed[sub] == "sensors/points") {
        ++c.raw;
        std::int64_t stamp;  // encapsulation (4) then Header.stamp_ns
        std::memcpy(&stamp, bytes + 13 + 4, 8);
        std::lock_guard lock(c.mutex);
        c.latency_ms.push_back((nowNs() - stamp) / 1e6);
      } else {
        ++c.view;
      }
    }
    buffer.consume(buffer.size());
  }
  boost::system::error_code ec;
  ws.next_layer().close(ec);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * v.size()))];
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Bridge throughput: clouds through ddsnav bridge to WebSocket clients (docs/benchmarks/bridge.md)."};
  int domain = 221;
  std::string dds = "fastdds", pub_dds = "fastdds", role;
  double mb = 1.0, hz = 10, seconds = 10;
  app.add_option("--domain", domain, "DDS domain id")->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--dds", dds, "the bridge's vendor");
  app.add_option("--publisher-dds", pub_dds, "the publisher's vendor");
  app.add_option("--cloud-mb", mb, "cloud size, MB")->check(CLI::PositiveNumber);
  app.add_option("--hz", hz, "clouds per second")->check(CLI::PositiveNumber);
  app.add_option("--seconds", seconds, "how long to publish")->check(CLI::PositiveNumber);
  app.add_option("--role", role, "internal: 'publisher' runs the publishing child");
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::warn);
  if (role == "publisher") return publisher(domain, pub_dds, mb, hz, seconds);

  bus::Participant participant({.vendor = bus::parseVendor(dds), .domain_id = domain, .name = "bench-bridge"});
  bridge::BridgeOptions options;
  options.server.port = 0;
  bridge::Bridge bridge(participant, options);
  std::atomic<bool> stop{false};
  std::vector<std::unique_ptr<Client>> clients;
  for (const char* name : {"reader-1", "reader-2", "stalled"}) {
    auto c = std::make_unique<Client>();
    c->name = name;
    c->reads = std::string(name) != "stalled";
    clients.push_back(std::move(c));
  }

  int out[2];
  if (::pipe(out) != 0) return 1;
  const pid_t child = ::fork();
  if (child == 0) {
    ::dup2(out[1], STDOUT_FILENO);
    const std::string d = std::to_string(domain), m = std::to_string(mb), h = std::to_string(hz), s = std::to_string(seconds);
    ::execl("/proc/self/exe", "bench-bridge", "--role", "publisher", "--domain", d.c_str(), "--publisher-dds", pub_dds.c_str(),
            "--cloud-mb", m.c_str(), "--hz", h.c_str(), "--seconds", s.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(out[1]);
  for (auto& c : clients) c->thread = std::thread([&, cp = c.get()] {
    try {
      runClient(*cp, bridge.port(), stop);
    } catch (const std::exception& e) {
      if (!stop) std::fprintf(stderr, "%s: %s\n", cp->name.c_str(), e.what());
    }
  });
  // The bridge's main loop until the publisher is done.
  int status = 0;
  while (::waitpid(child, &status, WNOHANG) == 0) {
    bridge.poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  char line[64] = {0};
  const ssize_t n = ::read(out[0], line, sizeof line - 1);
  const long published = n > 0 ? std::atol(line) : -1;
  std::this_thread::sleep_for(std::chrono::seconds(2));  // let the readers drain
  const auto stats = bridge.stats();
  // The clients' threads stay blocked in read (nothing more comes) or idle (the stalled one): the process
  // ends with _exit below instead of joining them.
  stop = true;
  const std::uint64_t on_bus = stats.received_by_topic.count("sensors/points") ? stats.received_by_topic.at("sensors/points") : 0;
  std::printf("published %ld clouds of %.2f MB at %.0f Hz (publisher %s, bridge %s)\n", published, mb, hz, pub_dds.c_str(), dds.c_str());
  std::printf("bridge took from the bus: %llu (bus-side loss %ld), Foxglove views made %llu (%llu not converted)\n",
              static_cast<unsigned long long>(on_bus), published - static_cast<long>(on_bus),
              static_cast<unsigned long long>(stats.derived), static_cast<unsigned long long>(stats.derive_dropped));
  std::printf("%-10s %8s %8s %10s %10s %10s %9s\n", "client", "raw", "view", "MB", "p50 ms", "p99 ms", "dropped");
  for (const auto& client : clients) {
    auto& c = *client;
    std::lock_guard lock(c.mutex);
    std::uint64_t dropped = 0;
    for (const auto& s : stats.server.clients)
      if (s.remote == "127.0.0.1:" + std::to_string(c.local_port.load())) dropped = s.dropped;
    std::printf("%-10s %8llu %8llu %10.1f %10.2f %10.2f %9llu\n", c.name.c_str(), static_cast<unsigned long long>(c.raw.load()),
                static_cast<unsigned long long>(c.view.load()), c.bytes / 1e6, percentile(c.latency_ms, 0.5), percentile(c.latency_ms, 0.99),
                static_cast<unsigned long long>(dropped));
  }
  std::fflush(stdout);
  ::_exit(published == static_cast<long>(on_bus) ? 0 : 1);  // the stalled client's thread stays blocked: no join
}
