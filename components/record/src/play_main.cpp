// ddsnav play: republishes a recording's raw payloads with the recorded timing; --clock drives
// system/clock so components run with `--clock topic` follow the recorded time. On a terminal: space
// pauses/resumes, `s` steps one message while paused, and a progress bar shows the playback time.
#include <ddsnav/record/recorder.hpp>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <poll.h>
#include <signal.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <thread>

using namespace ddsnav;

namespace {
std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop.store(true); }

// The terminal in single-key mode (no echo, no line buffering) while playing; restored on exit.
class KeyboardControl {
 public:
  explicit KeyboardControl(record::PlaybackControl& control) : control_(control) {
    // Only in the terminal's foreground: a background job (or a child of `ddsnav launch` in its own
    // process group) changing the terminal would be stopped by SIGTTOU.
    if (!::isatty(STDIN_FILENO) || ::tcgetpgrp(STDIN_FILENO) != ::getpgrp() || ::tcgetattr(STDIN_FILENO, &saved_) != 0) return;
    termios raw = saved_;
    raw.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO);
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    if (::tcsetattr(STDIN_FILENO, TCSANOW, &raw) != 0) return;
    active_ = true;
    thread_ = std::thread([this] { readKeys(); });
  }
  ~KeyboardControl() {
    done_ = true;
    if (thread_.joinable()) thread_.join();
    if (active_) ::tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }
  bool active() const { return active_; }

 private:
  void readKeys() {
    while (!done_ && !g_stop.load()) {
      pollfd fd{STDIN_FILENO, POLLIN, 0};
      if (::poll(&fd, 1, 100) <= 0) continue;
      char key = 0;
      if (::read(STDIN_FILENO, &key, 1) != 1) continue;
      if (key == ' ') control_.paused.store(!control_.paused.load());
      if (key == 's' || key == 'S') {
        control_.paused.store(true);
        control_.steps.fetch_add(1);
      }
    }
  }
  record::PlaybackControl& control_;
  termios saved_{};
  bool active_ = false;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

// "[#########---------]  12.3 / 40.0 s  published 1234  PAUSED" on one line, redrawn in place.
void drawProgressBar(const record::PlaybackProgress& p) {
  constexpr int kWidth = 30;
  const double fraction = p.duration_s > 0 ? std::clamp(p.recorded_s / p.duration_s, 0.0, 1.0) : 1.0;
  const int filled = static_cast<int>(fraction * kWidth + 0.5);
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.append(static_cast<std::size_t>(kWidth - filled), '-');
  std::printf("\r[%s] %7.1f / %.1f s  published %llu%s%s   ", bar.c_str(), p.recorded_s, p.duration_s,
              static_cast<unsigned long long>(p.published), p.passes ? (" pass " + std::to_string(p.passes + 1)).c_str() : "",
              p.paused ? "  PAUSED (space: resume, s: step)" : "                                ");
  std::fflush(stdout);
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Replay an MCAP recording onto DDS (docs/record.md)."};
  std::string path;
  record::PlayerOptions options;
  std::string dds;   // empty: DDSNAV_DDS, else fastdds
  int domain = -1;   // unset: DDSNAV_DOMAIN, else 0
  double wait_s = 2.0;
  double settle_s = 1.0;
  double linger_s = 1.0;
  app.add_option("file", path, "recording (.mcap)")->required();
  app.add_option("--rate", options.rate, "playback speed factor")->check(CLI::PositiveNumber);
  app.add_option("--topics", options.topics, "topics to replay (comma separated; default: all but system/status)")->delimiter(',');
  app.add_flag("--loop", options.loop, "start over at the end");
  app.add_flag("--clock", options.clock, "publish system/clock following the recorded time");
  app.add_option("--clock-hz", options.clock_hz, "system/clock publish rate")->check(CLI::PositiveNumber);
  app.add_option("--start", options.start_s, "skip the first S seconds")->check(CLI::NonNegativeNumber);
  app.add_option("--end", options.end_s, "stop at S seconds from the recording's start")->check(CLI::NonNegativeNumber);
  std::vector<std::string> remaps;
  app.add_option("--remap", remaps, "publish recorded topic FROM as TO (FROM=TO; repeatable)");
  app.add_option("--wait-subscribers", wait_s, "s to wait per topic for a subscriber before starting")->check(CLI::NonNegativeNumber);
  app.add_option("--settle", settle_s, "s to pause after subscribers matched, so they see us too")->check(CLI::NonNegativeNumber);
  app.add_option("--linger", linger_s, "s to keep the writers after the last message, for reliable resends")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--domain", domain, "DDS domain id (env DDSNAV_DOMAIN)")->check(CLI::Range(0, bus::kMaxDomainId));
  app.add_option("--dds", dds, "DDS vendor: fastdds | cyclonedds (env DDSNAV_DDS)");
  CLI11_PARSE(app, argc, argv);
  spdlog::set_pattern("[%H:%M:%S.%e] [play] [%^%l%$] %v");
  for (const std::string& r : remaps) {
    const auto eq = r.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == r.size()) {
      spdlog::error("--remap '{}': expected FROM=TO, two topic names", r);
      return 2;
    }
    if (!options.remap.emplace(r.substr(0, eq), r.substr(eq + 1)).second) {
      spdlog::error("--remap: topic '{}' remapped twice", r.substr(0, eq));
      return 2;
    }
  }
  options.wait_subscribers = std::chrono::milliseconds(static_cast<long>(wait_s * 1000));
  options.settle = std::chrono::milliseconds(static_cast<long>(settle_s * 1000));

  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  try {
    const bus::Vendor vendor = dds.empty() ? bus::vendorFromEnvironment() : bus::parseVendor(dds);
    if (domain < 0) domain = bus::domainFromEnvironment(0);
    record::McapReader file(path);
    if (file.truncated())
      spdlog::warn("{}: truncated at byte {} ({}); playing what is complete", path, file.truncatedAt(), file.truncationReason());
    bus::Participant participant({.vendor = vendor, .domain_id = domain, .name = "ddsnav-play"});
    // Keys and the progress bar only on a terminal; otherwise a plain progress line on stderr.
    const bool bar = ::isatty(STDOUT_FILENO);
    const bool tty = ::isatty(STDERR_FILENO);
    record::PlaybackControl control;
    KeyboardControl keys(control);
    if (keys.active()) options.control = &control;
    const auto result = record::play(participant, file, options, g_stop, [&](const record::PlaybackProgress& p) {
      if (bar) return drawProgressBar(p);
      std::fprintf(stderr, "%s%.1f / %.1f s  published %llu%s", tty ? "\r" : "", p.recorded_s, p.duration_s,
                   static_cast<unsigned long long>(p.published), tty ? "   " : "\n");
    });
    if (bar) std::printf("\n");
    else if (tty) std::fprintf(stderr, "\n");
    if (result.damaged_chunks)
      spdlog::warn("{} damaged chunk(s) skipped; their messages were not published", result.damaged_chunks);
    spdlog::info("published {} messages{}", result.published,
                 result.failed ? " (" + std::to_string(result.failed) + " refused by the vendor)" : std::string());
    // Reliable samples not yet acknowledged are resent on the next heartbeat; the bus cannot wait for
    // acknowledgements, so keep the writers a while before they go away.
    for (int i = 0; i < static_cast<int>(linger_s * 10) && !g_stop.load(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return result.failed ? 1 : 0;
  } catch (const std::invalid_argument& e) {
    spdlog::error("{}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
