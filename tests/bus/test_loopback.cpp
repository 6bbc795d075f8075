// Proof that the default participants stay on loopback: after traffic has flowed, none of this
// process's UDP sockets is bound to a non-loopback address, none is bound to the RTPS multicast ports,
// there are no IPv6 sockets, and no socket is a member of the SPDP multicast group -- even with vendor
// environment variables set that would enable multicast.
#include "samples.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <dirent.h>
#include <errno.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>
#include <map>
#include <sstream>

namespace ddsnav::test {
namespace {

using bus::Vendor;

// inode -> fd of every socket this process has open.
std::map<unsigned long, int> socketInodes() {
  std::map<unsigned long, int> inodes;
  DIR* dir = opendir("/proc/self/fd");
  while (dirent* e = readdir(dir)) {
    char target[128] = {};
    std::string path = std::string("/proc/self/fd/") + e->d_name;
    ssize_t n = readlink(path.c_str(), target, sizeof(target) - 1);
    if (n <= 0) continue;
    unsigned long inode = 0;
    if (std::sscanf(target, "socket:[%lu]", &inode) == 1) inodes[inode] = std::atoi(e->d_name);
  }
  closedir(dir);
  return inodes;
}

struct UdpSocket {
  std::string address;  // dotted quad
  unsigned port = 0;
  int fd = -1;
};

// Rows of /proc/self/net/<table> whose inode belongs to this process.
std::vector<UdpSocket> ourSockets(const std::string& table) {
  std::map<unsigned long, int> inodes = socketInodes();
  std::ifstream in("/proc/self/net/" + table);
  std::string line;
  std::getline(in, line);  // header
  std::vector<UdpSocket> sockets;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    std::string slot, local, remote, state, queues, timer, retr;
    unsigned long uid = 0, timeout = 0, inode = 0;
    row >> slot >> local >> remote >> state >> queues >> timer >> retr >> uid >> timeout >> inode;
    auto it = inodes.find(inode);
    if (it == inodes.end()) continue;
    UdpSocket s;
    s.fd = it->second;
    s.port = std::stoul(local.substr(local.find(':') + 1), nullptr, 16);
    if (table == "udp") {
      in_addr addr{};
      addr.s_addr = static_cast<in_addr_t>(std::stoul(local.substr(0, 8), nullptr, 16));
      s.address = inet_ntoa(addr);
    } else {
      s.address = local.substr(0, local.find(':'));
    }
    sockets.push_back(s);
  }
  return sockets;
}

// IP_DROP_MEMBERSHIP succeeds only if the socket had joined the group (and then undoes the join).
bool joinedGroup(int fd, const char* group) {
  ip_mreqn req{};
  inet_pton(AF_INET, group, &req.imr_multiaddr);
  return setsockopt(fd, IPPROTO_IP, IP_DROP_MEMBERSHIP, &req, sizeof(req)) == 0;
}

// Vendor environment variables that would turn multicast on if the bus honoured them: it must not.
class StrayVendorConfig {
 public:
  StrayVendorConfig() {
    std::ofstream(path_) << "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n"
                            "<profiles xmlns=\"http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles\">\n"
                            "<participant profile_name=\"stray\" is_default_profile=\"true\"><rtps/></participant>\n"
                            "</profiles>\n";
    setenv("FASTRTPS_DEFAULT_PROFILES_FILE", path_.c_str(), 1);
    setenv("CYCLONEDDS_URI",
           "<CycloneDDS><Domain id=\"any\"><General><AllowMulticast>true</AllowMulticast></General></Domain>"
           "</CycloneDDS>",
           1);
  }
  ~StrayVendorConfig() {
    unsetenv("FASTRTPS_DEFAULT_PROFILES_FILE");
    unsetenv("CYCLONEDDS_URI");
    std::remove(path_.c_str());
  }

 private:
  std::string path_ = "/tmp/ddsnav_stray_fastdds_" + std::to_string(getpid()) + ".xml";
};

void checkLoopbackOnly(Vendor vendor, int domain_offset) {
  const int domain = testDomain(domain_offset);
  StrayVendorConfig stray;
  bus::Participant a(options(vendor, domain_offset, "loopback-a"));
  bus::Participant b(options(vendor, domain_offset, "loopback-b"));
  auto pub = a.publisher<msg::Path>("planning/path", bus::Qos::state());
  auto inbox = b.inbox<msg::Path>("planning/path", bus::Qos::state());
  pub.publish(makeSample<msg::Path>(1));
  ASSERT_TRUE(inbox.wait(kWait).has_value()) << "no traffic flowed, the check below would prove nothing";

  std::vector<UdpSocket> sockets = ourSockets("udp");
  ASSERT_FALSE(sockets.empty()) << "found no UDP socket of this process; the /proc parsing is broken";
  const unsigned spdp_multicast_port = 7400 + 250 * domain;      // PB + DG * domain + d0
  const unsigned user_multicast_port = 7400 + 250 * domain + 1;  // + d2
  for (const UdpSocket& s : sockets) {
    SCOPED_TRACE(s.address + ":" + std::to_string(s.port));
    EXPECT_TRUE(s.address == "127.0.0.1" || s.address == "0.0.0.0") << "bound to a non-loopback address";
    EXPECT_NE(s.port, spdp_multicast_port);
    EXPECT_NE(s.port, user_multicast_port);
    EXPECT_FALSE(joinedGroup(s.fd, "239.255.0.1")) << "member of the SPDP multicast group";
  }
  EXPECT_TRUE(ourSockets("udp6").empty()) << "IPv6 UDP sockets open";
}

TEST(BusLoopback, FastDdsDefaultsStayOnLoopback) { checkLoopbackOnly(Vendor::FastDDS, 16); }
TEST(BusLoopback, CycloneDdsDefaultsStayOnLoopback) { checkLoopbackOnly(Vendor::CycloneDDS, 17); }

}  // namespace
}  // namespace ddsnav::test
