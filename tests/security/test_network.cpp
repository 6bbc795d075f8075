// The demo split over two "hosts": two network namespaces this test creates, joined by a veth pair
// created inside them (no link and no address ever exists in the host namespace). Host A runs sim and
// its launcher (Fast DDS) and tracker (Cyclone DDS), host B perception and planner (Fast DDS), mapper and
// the monitor (Cyclone DDS) and `ddsnav record` (Fast DDS), each launcher configured with `network:`
// (interface + unicast peer): both hosts mix the vendors, and every hop between the hosts crosses vendors
// somewhere. (Host B starts while its veth end may still be without carrier; the bus waits for it, else
// Fast DDS would drop the interface and run without UDP: "All whitelist interfaces were filtered out".)
// The vehicle must reach the goal, the recording must hold topics of both hosts, every socket of the
// demo must be bound inside its namespace (its veth address, loopback, or the wildcard, which there
// means only those), and the host namespace must see none of it. Needs root; skips otherwise.
// Domains 137 and 138.
#include <ddsnav/testing/harness.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cerrno>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

using namespace ddsnav;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

constexpr int kDomain = 137;
constexpr int kCarrierDomain = 138;  // inside a namespace of its own: nothing else can be there

// Runs a shell command, returning its exit status and (stdout + stderr) text.
std::pair<int, std::string> run(const std::string& command) {
  std::string text;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return {-1, "popen failed"};
  char buffer[4096];
  while (std::fgets(buffer, sizeof(buffer), pipe) != nullptr) text += buffer;
  const int status = ::pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, text};
}

// Namespaces of an earlier run of this test that was killed before its destructors ran (named
// ddsnav<pid>a/b/c after its pid): deleted when that pid is gone, so a killed run leaves nothing behind for long.
void removeStaleNamespaces() {
  std::istringstream names(run("ip netns list").second);
  for (std::string line; std::getline(names, line);) {
    const std::string name = line.substr(0, line.find(' '));
    static const std::regex ours(R"(ddsnav([0-9]+)[abc])");
    std::smatch m;
    if (!std::regex_match(name, m, ours)) continue;
    if (::kill(std::stoi(m[1].str()), 0) == 0 || errno == EPERM) continue;  // its process still runs
    run("ip netns pids " + name + " | xargs -r kill -9");
    run("ip netns del " + name);
  }
}

// Two namespaces and the veth pair between them, named uniquely for this run; removed on destruction,
// which also removes the veth ends (they live only inside the namespaces).
class TwoHosts {
 public:
  TwoHosts() {
    const std::string id = std::to_string(::getpid() % 100000);
    a = "ddsnav" + id + "a";
    b = "ddsnav" + id + "b";
    veth_a = "dnva" + id;
    veth_b = "dnvb" + id;
    const int subnet = static_cast<int>(::getpid() % 250) + 1;
    address_a = "10.231." + std::to_string(subnet) + ".1";
    address_b = "10.231." + std::to_string(subnet) + ".2";
  }
  ~TwoHosts() {
    for (const std::string& ns : created_) {
      // Processes still inside (after a failure) are ended by the harness; delete the namespace anyway.
      run("ip netns pids " + ns + " | xargs -r kill -9");
      run("ip netns del " + ns);
    }
  }
  // Empty on success, else why the namespaces could not be made.
  std::string create() {
    if (::geteuid() != 0) return "not root";
    removeStaleNamespaces();
    for (const std::string& ns : {a, b}) {
      auto [rc, out] = run("ip netns add " + ns);
      if (rc != 0) return "ip netns add " + ns + ": " + out;
      created_.push_back(ns);
    }
    const std::vector<std::string> steps = {
        "ip -n " + a + " link add " + veth_a + " type veth peer name " + veth_b + " netns " + b,
        "ip -n " + a + " addr add " + address_a + "/24 dev " + veth_a,
        "ip -n " + b + " addr add " + address_b + "/24 dev " + veth_b,
        "ip -n " + a + " link set lo up", "ip -n " + b + " link set lo up",
        "ip -n " + a + " link set " + veth_a + " up", "ip -n " + b + " link set " + veth_b + " up"};
    for (const std::string& step : steps) {
      auto [rc, out] = run(step);
      if (rc != 0) return step + ": " + out;
    }
    return "";
  }
  std::string a, b, veth_a, veth_b, address_a, address_b;

 private:
  std::vector<std::string> created_;
};

// Local addresses of the UDP/TCP sockets in namespace `ns` owned by processes named like ddsnav's.
std::vector<std::string> socketAddresses(const std::string& ns) {
  auto [rc, out] = run("ip netns exec " + ns + " ss -H -uatnp");
  std::vector<std::string> addresses;
  std::istringstream lines(out);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.find("ddsnav") == std::string::npos) continue;
    std::istringstream fields(line);
    std::string netid, state, recv_q, send_q, local;
    fields >> netid >> state >> recv_q >> send_q >> local;
    addresses.push_back(local.substr(0, local.rfind(':')));
  }
  return addresses;
}

std::string launchFile(const std::string& name, const std::string& interface, const std::string& peer,
                       const std::string& processes) {
  return "name: " + name + "\nshutdown_timeout_s: 5\nnetwork: {interface: " + interface + ", peers: [" + peer +
         "]}\nprocesses:\n" + processes;
}

}  // namespace

TEST(Network, TheDemoSplitOverTwoNamespacesReachesTheGoal) {
  TwoHosts hosts;
  const std::string why = hosts.create();
  if (!why.empty()) GTEST_SKIP() << "cannot make network namespaces here (" << why << "); skipping";

  const fs::path dir = fs::temp_directory_path() / ("ddsnav_netns_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string scenario = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml";
  const std::string out = (dir / "out").string(), bag = (dir / "both.mcap").string();
  std::ofstream(dir / "a.yaml") << launchFile("host_a", hosts.veth_a, hosts.address_b,
      "  - {name: sim, command: ddsnav-sim, dds: fastdds, params: {scenario: \"" + scenario + "\"}}\n"
      "  - {name: tracker, command: ddsnav-tracker, dds: cyclonedds, after: [sim],\n"
      "     params: {scenario: \"" + scenario + "\", planner: gart}}\n");
  std::ofstream(dir / "b.yaml") << launchFile("host_b", hosts.veth_b, hosts.address_a,
      "  - {name: record, command: ddsnav-record, dds: fastdds, wait_ready: false, args: [-o, \"" + bag + "\", --all]}\n"
      "  - {name: perception, command: ddsnav-perception, dds: fastdds}\n"
      "  - {name: mapper, command: ddsnav-mapper, dds: cyclonedds, params: {save_path: \"" + out + "/map.bt\"}}\n"
      "  - {name: planner, command: ddsnav-planner, dds: fastdds, after: [perception], params: {scenario: \"" + scenario + "\"}}\n"
      "  - {name: monitor, command: ddsnav-monitor, dds: cyclonedds, after: [planner, mapper], required: true,\n"
      "     params: {scenario: \"" + scenario + "\", out_dir: \"" + out + "\", timeout_s: \"120\"}}\n");

  // The observer stays in the host namespace, on loopback: it must discover nothing of the demo.
  harness::Harness h(kDomain);
  const std::string launch = harness::Harness::binDir() + "/ddsnav-launch";
  h.start({.name = "host_b", .command = "ip",
           .args = {"netns", "exec", hosts.b, launch, (dir / "b.yaml").string(), "--domain", std::to_string(kDomain), "--dds",
                    "cyclonedds"}});
  // Host A once B's planner is up, so the tracker's first plan request finds it.
  const auto b_ready_by = std::chrono::steady_clock::now() + 60s;
  while (h.log("host_b").find("monitor is ready") == std::string::npos && h.running("host_b") &&
         std::chrono::steady_clock::now() < b_ready_by)
    std::this_thread::sleep_for(200ms);
  ASSERT_NE(h.log("host_b").find("monitor is ready"), std::string::npos) << h.log("host_b");
  h.start({.name = "host_a", .command = "ip",
           .args = {"netns", "exec", hosts.a, launch, (dir / "a.yaml").string(), "--domain", std::to_string(kDomain)}});

  // Mid-run: the sockets of each namespace, and what the host namespace sees.
  const auto a_ready_by = std::chrono::steady_clock::now() + 60s;
  while (h.log("host_a").find("tracker is ready") == std::string::npos && h.running("host_a") &&
         std::chrono::steady_clock::now() < a_ready_by)
    std::this_thread::sleep_for(200ms);
  ASSERT_NE(h.log("host_a").find("tracker is ready"), std::string::npos) << h.log("host_a");
  std::this_thread::sleep_for(3s);
  for (const auto& [ns, own] : {std::pair{hosts.a, hosts.address_a}, std::pair{hosts.b, hosts.address_b}}) {
    const std::vector<std::string> addresses = socketAddresses(ns);
    EXPECT_GE(addresses.size(), 4u) << "too few sockets seen in " << ns << ": " << run("ip netns exec " + ns + " ss -uatnp").second;
    for (const std::string& address : addresses)
      EXPECT_TRUE(address == own || address == "127.0.0.1" || address == "0.0.0.0" || address == "*")
          << ns << ": a socket bound to " << address << "\n" << run("ip netns exec " + ns + " ss -uatnp").second;
  }
  const std::string host_links = run("ip -o link show").second, host_addresses = run("ip -o -4 addr show").second;
  EXPECT_EQ(host_links.find(hosts.veth_a), std::string::npos) << host_links;
  EXPECT_EQ(host_links.find(hosts.veth_b), std::string::npos) << host_links;
  EXPECT_EQ(host_addresses.find("10.231."), std::string::npos) << host_addresses;
  // Other ddsnav processes may run in the host namespace at the same time: look for the demo's own pids.
  const std::string host_sockets = run("ss -H -uatnp").second;
  for (const std::string& ns : {hosts.a, hosts.b}) {
    std::istringstream pids(run("ip netns pids " + ns).second);
    int count = 0;
    // The only host-namespace sockets a demo process may hold are this test's own, inherited through
    // fork/exec (ss then lists both owners on one line); none is one the demo opened.
    const std::string self = "pid=" + std::to_string(::getpid()) + ",";
    for (std::string pid; pids >> pid; ++count) {
      std::istringstream lines(host_sockets);
      for (std::string line; std::getline(lines, line);) {
        if (line.find("pid=" + pid + ",") == std::string::npos) continue;
        EXPECT_NE(line.find(self), std::string::npos) << "process " << pid << " of " << ns << " opened a host socket: " << line;
      }
    }
    EXPECT_GE(count, 3) << "too few processes in " << ns;
  }
  EXPECT_FALSE(h.bus().waitForTopic("vehicle/state", 2s).has_value()) << "the host namespace discovered the demo's topics";

  const auto deadline = std::chrono::steady_clock::now() + 200s;
  while (h.running("host_b") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(200ms);
  ASSERT_FALSE(h.running("host_b")) << "host B did not end within 200 s\n" << h.log("host_b");
  const int status = h.stop("host_b");
  h.stop("host_a");
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status << "\n" << h.log("host_b") << h.log("host_a");
  // Fast DDS says this when it dropped the interface and went on without UDP.
  for (const char* host : {"host_a", "host_b"})
    EXPECT_EQ(h.log(host).find("whitelist interfaces were filtered out"), std::string::npos) << h.log(host);

  std::ifstream summary_file(fs::path(out) / "summary.json");
  ASSERT_TRUE(summary_file.good()) << "no summary.json\n" << h.log("host_b") << h.log("host_a");
  const auto summary = nlohmann::json::parse(summary_file, nullptr, false);
  ASSERT_TRUE(summary.is_object());
  EXPECT_TRUE(summary.value("goal_reached", false)) << summary.dump(2);

  // The recording on host B holds topics published on both hosts.
  auto [info_rc, info] = run(harness::Harness::binDir() + "/ddsnav-info --json " + bag);
  ASSERT_EQ(info_rc, 0) << info;
  for (const char* topic : {"vehicle/state", "sensors/points", "control/cmd_vel", "perception/obstacles", "planning/path"})
    EXPECT_NE(info.find(std::string("\"") + topic + "\""), std::string::npos) << topic << " not recorded\n" << info;
  fs::remove_all(dir);
}

// A link without carrier (its veth peer is down) is refused by name after the bus's bounded wait, on both
// vendors: Fast DDS on its own would drop the interface from its whitelist and run on with no UDP at all.
TEST(Network, AnInterfaceWithoutCarrierIsRefusedByName) {
  if (::geteuid() != 0) GTEST_SKIP() << "cannot make network namespaces here (not root); skipping";
  const std::string id = std::to_string(::getpid() % 100000);
  const std::string ns = "ddsnav" + id + "c", link = "dnvc" + id, peer = "dnvd" + id;
  removeStaleNamespaces();
  if (auto [rc, out] = run("ip netns add " + ns); rc != 0) GTEST_SKIP() << "cannot make network namespaces here (" << out << "); skipping";
  for (const std::string& step : {"ip -n " + ns + " link add " + link + " type veth peer name " + peer,
                                  "ip -n " + ns + " addr add 10.232.1.1/24 dev " + link, "ip -n " + ns + " link set " + link + " up"}) {
    auto [rc, out] = run(step);
    ASSERT_EQ(rc, 0) << step << ": " << out;
  }
  for (const char* vendor : {"fastdds", "cyclonedds"}) {
    const auto started = std::chrono::steady_clock::now();
    auto [rc, out] = run("ip netns exec " + ns + " " + harness::Harness::binDir() + "/ddsnav-talker --dds " + vendor +
                         " --domain " + std::to_string(kCarrierDomain) + " --count 1 --network " + link + " --peers 10.232.1.2");
    EXPECT_NE(rc, 0) << vendor << ": " << out;
    EXPECT_NE(out.find("network interface '" + link + "' is up but has no carrier"), std::string::npos) << vendor << ": " << out;
    EXPECT_LT(std::chrono::steady_clock::now() - started, 20s) << vendor;
  }
  run("ip netns del " + ns);
}
