// ddsnav-test-with-domain COMMAND [ARGS...]: runs COMMAND with a DDS domain id from the test allocator held
// for as long as it runs; every argument "@DOMAIN@" becomes that id, and DDSNAV_DOMAIN is set to it. For
// tests that are not C++ (tests/bridge's node scripts). Exits with COMMAND's status.
#include <ddsnav/testing/domain.hpp>
#include <ddsnav/testing/end_with_parent.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: ddsnav-test-with-domain COMMAND [ARGS...]   (@DOMAIN@ in ARGS: the domain id)\n");
    return 2;
  }
  try {
    const ddsnav::testing::DomainLease domain;
    std::vector<std::string> args(argv + 1, argv + argc);
    for (std::string& a : args)
      if (a == "@DOMAIN@") a = domain.str();
    std::vector<char*> raw;
    for (std::string& a : args) raw.push_back(a.data());
    raw.push_back(nullptr);
    ::setenv("DDSNAV_DOMAIN", domain.str().c_str(), 1);
    const pid_t parent = ::getpid();
    const pid_t child = ::fork();
    if (child < 0) throw std::runtime_error("fork failed");
    if (child == 0) {
      // The lease lives as long as this process: a command that outlived it (this process killed, as ctest does
      // at a timeout) would keep using an id the next test may take.
      ddsnav::testing::endWithParent(parent);
      ::execvp(raw[0], raw.data());
      std::perror(raw[0]);
      ::_exit(127);
    }
    int status = 0;
    while (::waitpid(child, &status, 0) < 0) {
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddsnav-test-with-domain: %s\n", e.what());
    return 1;
  }
}
