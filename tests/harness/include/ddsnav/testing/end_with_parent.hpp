// For a test's child process, between fork and exec: the child gets SIGTERM when the process that forked it ends,
// even one that ends without running its destructors (a sanitizer's report, SIGKILL, ctest's timeout). An orphaned
// test peer kept its durable samples on a domain id the next test leased, and that test got them (2026-12-07).
#pragma once

#include <sys/prctl.h>
#include <unistd.h>

#include <csignal>

namespace ddsnav::testing {

// `parent`: getpid() taken before the fork. Exits (127) when the parent died between fork and this call.
inline void endWithParent(pid_t parent) {
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);
  if (::getppid() != parent) ::_exit(127);
}

}  // namespace ddsnav::testing
