#include "ddsnav/testing/domain.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <thread>

namespace ddsnav::testing {

namespace fs = std::filesystem;

namespace {

std::string lockFolder() {
  const char* dir = std::getenv("DDSNAV_TEST_DOMAIN_LOCKS");
  return dir && *dir ? dir : (fs::temp_directory_path() / "ddsnav-test-domains").string();
}

int parseBound(const std::string& text, const std::string& whole) {
  std::size_t used = 0;
  int value = -1;
  try {
    value = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty())
    throw std::invalid_argument("DDSNAV_TEST_DOMAINS='" + whole + "': expected LOW-HIGH, two integers");
  return value;
}

// An id released less than this long ago is taken only when every other id is busy or as recent: a test's processes
// may outlive its lease by a few seconds (a launcher's children shutting down), and a test that took the id at once
// heard them. A CI run, 2026-12-07: a planner on domain 153 answered a test that only listens on planning/request,
// 3 s into it. The release time is kept in the lock file (8 bytes, seconds since the epoch).
constexpr double kCooldownS = 30.0;

double nowS() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

bool releasedRecently(int fd) {
  double released = 0.0;
  if (::pread(fd, &released, sizeof released, 0) != static_cast<ssize_t>(sizeof released)) return false;  // never released
  const double age = nowS() - released;
  return age >= 0.0 && age < kCooldownS;
}

}  // namespace

DomainPool domainPoolFromEnvironment() {
  DomainPool pool{kMinTestDomain, kMaxTestDomain};
  const char* value = std::getenv("DDSNAV_TEST_DOMAINS");
  if (!value || !*value) return pool;
  const std::string text = value;
  const auto dash = text.find('-');
  if (dash == std::string::npos)
    throw std::invalid_argument("DDSNAV_TEST_DOMAINS='" + text + "': expected LOW-HIGH, two integers");
  const int low = parseBound(text.substr(0, dash), text), high = parseBound(text.substr(dash + 1), text);
  if (low < kMinTestDomain || high > kMaxTestDomain || low > high)
    throw std::invalid_argument("DDSNAV_TEST_DOMAINS='" + text + "': expected " + std::to_string(kMinTestDomain) +
                                " <= LOW <= HIGH <= " + std::to_string(kMaxTestDomain));
  return {low, high};
}

DomainLease::DomainLease(double timeout_s) {
  const DomainPool pool = domainPoolFromEnvironment();
  const std::string folder = lockFolder();
  std::error_code ignored;
  fs::create_directories(folder, ignored);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  // Scan from a point that moves on with every lease (and differs between processes), so an id just
  // released is not taken again at once: a new test must not hear the lingering participants of the last.
  static std::atomic<unsigned> leases{static_cast<unsigned>(::getpid()) * 7u};
  const int size = pool.high - pool.low + 1;
  const int first = static_cast<int>(leases++ % static_cast<unsigned>(size));
  for (;;) {
    // First an id not released within kCooldownS, then any free one.
    for (const bool cooled_only : {true, false})
      for (int step = 0; step < size; ++step) {
        const int id = pool.low + (first + step) % size;
        if (!pool.contains(id)) continue;
        const std::string path = folder + "/domain-" + std::to_string(id) + ".lock";
        const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
        if (fd < 0) continue;
        // flock locks belong to the open file description: a second lease in this process on the same id
        // opens its own description and is refused like any other process.
        if (::flock(fd, LOCK_EX | LOCK_NB) == 0) {
          if (!(cooled_only && releasedRecently(fd))) {
            id_ = id;
            fd_ = fd;
            return;
          }
        }
        ::close(fd);  // closing releases a lock taken above
      }
    if (std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error("DomainLease: every test domain id in " + std::to_string(pool.low) + ".." +
                               std::to_string(pool.high) + " is taken (lock files in " + folder + ")");
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

DomainLease::DomainLease(DomainLease&& other) noexcept : id_(other.id_), fd_(other.fd_) {
  other.id_ = -1;
  other.fd_ = -1;
}

DomainLease::~DomainLease() {
  if (fd_ < 0) return;
  const double released = nowS();
  if (::pwrite(fd_, &released, sizeof released, 0) != static_cast<ssize_t>(sizeof released)) {
    // Not stamped: the id may be taken again at once, as before the cooldown; nothing else depends on it.
  }
  ::close(fd_);  // releases the lock
}

}  // namespace ddsnav::testing
