// ddsnav play: republishes a recording's raw payloads with the recorded timing; --clock drives
// system/clock so components run with `--clock topic` follow the recorded time. On a terminal: space
// pauses/resumes, `s` steps one message while paused, and a progress bar shows the playback time.
#include <ddsnav/record/recorder.hpp>
#include <ddsnav/runtime/component.hpp>

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
// Set once the runtime is asked to shut down (SIGINT/SIGTERM): play() and the key reader poll it.
std::atomic<bool> g_stop{false};

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

struct PlayCommandLine {
  std::string path;
  record::PlayerOptions options;
  double wait_s = 2.0;
  double settle_s = 1.0;
  double linger_s = 1.0;

  void add(CLI::App& app) {
    app.add_option("file", path, "recording (.mcap)")->required();
    app.add_option("--rate", options.rate, "playback speed factor")->check(CLI::PositiveNumber);
    app.add_option("--topics", options.topics, "topics to replay (comma separated; default: all but system/status and system/progress)")->delimiter(',');
    app.add_flag("--loop", options.loop, "start over at the end");
    app.add_flag("--clock", options.clock, "publish system/clock following the recorded time");
    app.add_option("--clock-hz", options.clock_hz, "system/clock publish rate")->check(CLI::PositiveNumber);
    app.add_option("--start", options.start_s, "skip the first S seconds")->check(CLI::NonNegativeNumber);
    app.add_option("--end", options.end_s, "stop at S seconds from the recording's start")->check(CLI::NonNegativeNumber);
    app.add_option("--wait-subscribers", wait_s, "s to wait per topic for a subscriber before starting")->check(CLI::NonNegativeNumber);
    app.add_option("--settle", settle_s, "s to pause after subscribers matched, so they see us too")->check(CLI::NonNegativeNumber);
    app.add_option("--linger", linger_s, "s to keep the writers after the last message, for reliable resends")
        ->check(CLI::NonNegativeNumber);
  }
};

// The runtime's --remap FROM=TO and --namespace apply to the recorded topics (FROM: a recorded name).
void play(runtime::Context& ctx, PlayCommandLine& c) {
  auto& options = c.options;
  options.wait_subscribers = std::chrono::milliseconds(static_cast<long>(c.wait_s * 1000));
  options.settle = std::chrono::milliseconds(static_cast<long>(c.settle_s * 1000));
  options.linger = std::chrono::milliseconds(static_cast<long>(c.linger_s * 1000));
  std::thread stop_watch([&ctx] {
    while (!ctx.waitForShutdown(std::chrono::milliseconds(100)) && !g_stop.load()) {
    }
    g_stop = true;
  });
  struct Join {
    std::thread& t;
    ~Join() {
      g_stop = true;
      t.join();
    }
  } join{stop_watch};
  record::McapReader file(c.path);
  if (file.truncated())
    spdlog::warn("{}: truncated at byte {} ({}); playing what is complete", c.path, file.truncatedAt(), file.truncationReason());
  for (const auto& [id, channel] : file.channels()) {
    const std::string published = ctx.topic(channel.topic);
    if (published != channel.topic) options.remap[channel.topic] = published;
  }
  ctx.ready();  // a --remap of a topic the recording does not hold is refused here
  bus::Participant& participant = ctx.bus();
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
  if (result.damaged_chunks) spdlog::warn("{} damaged chunk(s) skipped; their messages were not published", result.damaged_chunks);
  spdlog::info("published {} messages{}", result.published,
               result.failed ? " (" + std::to_string(result.failed) + " refused by the vendor)" : std::string());
  if (result.failed) throw std::runtime_error(std::to_string(result.failed) + " message(s) refused by the vendor");
}

}  // namespace

int main(int argc, char** argv) {
  PlayCommandLine command_line;
  return runtime::runComponent(runtime::ComponentInfo{"play", {}, [&](CLI::App& app) { command_line.add(app); }}, argc, argv,
                               [&](runtime::Context& ctx) {
                                 try {
                                   play(ctx, command_line);
                                 } catch (const std::invalid_argument& e) {
                                   throw runtime::ParameterError(e.what());  // a bad option for this file: exit status 2
                                 }
                               });
}
