// Record tests keep their files in <temp>/<prefix><pid>; this removes that folder when the test program ends.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace ddsnav::record_test {

class ScratchCleanup : public ::testing::Environment {
 public:
  explicit ScratchCleanup(std::string prefix) : prefix_(std::move(prefix)) {}
  void TearDown() override {
    std::error_code ignored;  // best effort: a leftover temp folder must not fail the run
    std::filesystem::remove_all(std::filesystem::temp_directory_path() / (prefix_ + std::to_string(::getpid())), ignored);
  }

 private:
  std::string prefix_;
};

// Registers the cleanup; meant for a namespace-scope constant, so it runs before main.
inline bool removeScratchAtExit(const std::string& prefix) {
  ::testing::AddGlobalTestEnvironment(new ScratchCleanup(prefix));
  return true;
}

}  // namespace ddsnav::record_test
