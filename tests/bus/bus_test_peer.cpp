// Second process for the multi-process bus tests: echoes every message type from in/<Type> to
// out/<Type> (and in/BigCloud to out/BigCloud) on the vendor it is told, prints READY once its
// endpoints exist, and exits cleanly on SIGTERM/SIGINT. With --burst N it instead publishes one marker
// and then N samples back to back on burst/state (reliable, keep-last 1: a slow reader loses some), prints
// DONE and waits for the signal.
#include "samples.hpp"

#include <ddsnav/bus/bus.hpp>

#include <CLI/CLI.hpp>

#include <csignal>
#include <iostream>
#include <thread>

using namespace ddsnav;

namespace {

struct Echo {
  std::vector<bus::Subscription> subscriptions;
  std::vector<std::shared_ptr<void>> publishers;

  template <class T>
  void add(bus::Participant& p, const std::string& in, const std::string& out) {
    auto pub = std::make_shared<bus::Publisher<T>>(p.publisher<T>(out, bus::Qos::state(2)));
    publishers.push_back(pub);
    subscriptions.push_back(p.subscribe<T>(in, bus::Qos::state(2), [pub](const T& s) { pub->publish(s); }));
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bus test peer: echoes in/<Type> to out/<Type>"};
  std::string vendor = "fastdds";
  int domain = 0, burst = 0;
  app.add_option("--dds", vendor, "fastdds | cyclonedds");
  app.add_option("--domain", domain, "DDS domain id")->required();
  app.add_option("--burst", burst, "publish a marker then this many samples on burst/state")->check(CLI::Range(0, 1000000));
  CLI11_PARSE(app, argc, argv);

  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);  // before any DDS thread exists, so they inherit it

  try {
    bus::ParticipantOptions options;
    options.vendor = bus::parseVendor(vendor);
    options.domain_id = domain;
    options.name = "bus-test-peer";
    bus::Participant participant(options);
    if (burst > 0) {
      auto pub = participant.publisher<msg::VehicleState>("burst/state", bus::Qos::state(1));
      std::cout << "READY" << std::endl;
      if (!pub.waitForSubscribers(1, std::chrono::seconds(20))) {
        std::cerr << "bus_test_peer: no subscriber on burst/state\n";
        return 1;
      }
      // The marker goes alone, so the reader takes it before the burst and counts from it.
      pub.publish(test::makeSample<msg::VehicleState>(0));
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      for (int i = 1; i <= burst; ++i) pub.publish(test::makeSample<msg::VehicleState>(i));
      std::cout << "DONE" << std::endl;
      int sig = 0;
      sigwait(&signals, &sig);
      return 0;
    }
    Echo echo;
    test::forEachMessageType([&](auto proto) {
      using T = decltype(proto);
      echo.add<T>(participant, "in/" + test::shortName<T>(), "out/" + test::shortName<T>());
    });
    echo.add<msg::PointCloud>(participant, "in/BigCloud", "out/BigCloud");
    std::cout << "READY" << std::endl;
    int sig = 0;
    sigwait(&signals, &sig);
    echo.subscriptions.clear();
  } catch (const std::exception& e) {
    std::cerr << "bus_test_peer: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
