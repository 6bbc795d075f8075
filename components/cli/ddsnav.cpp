// `ddsnav <command> [args...]`: runs the executable `ddsnav-<command>` that sits beside this one, the
// way git runs its subcommands. Each command is then its own small program with its own dependencies,
// and a command that is not built simply does not show up.

#include <dirent.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

std::string executableDirectory() {
  char buffer[PATH_MAX];
  const ssize_t n = ::readlink("/proc/self/exe", buffer, sizeof(buffer) - 1);
  if (n <= 0) return ".";
  std::string path(buffer, static_cast<size_t>(n));
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}

std::vector<std::string> availableCommands(const std::string& dir) {
  std::vector<std::string> commands;
  if (DIR* d = ::opendir(dir.c_str())) {
    while (const dirent* entry = ::readdir(d)) {
      const std::string name = entry->d_name;
      const std::string prefix = "ddsnav-";
      if (name.rfind(prefix, 0) == 0 && ::access((dir + "/" + name).c_str(), X_OK) == 0) {
        commands.push_back(name.substr(prefix.size()));
      }
    }
    ::closedir(d);
  }
  std::sort(commands.begin(), commands.end());
  return commands;
}

int usage(const std::string& dir, FILE* out) {
  std::fprintf(out, "usage: ddsnav <command> [args...]   (ddsnav <command> --help for its options)\n\ncommands:\n");
  for (const auto& command : availableCommands(dir)) std::fprintf(out, "  %s\n", command.c_str());
  return out == stdout ? 0 : 2;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = executableDirectory();
  if (argc < 2) return usage(dir, stderr);
  const std::string command = argv[1];
  if (command == "-h" || command == "--help" || command == "help") return usage(dir, stdout);

  const std::string target = dir + "/ddsnav-" + command;
  std::vector<char*> args;
  args.push_back(const_cast<char*>(target.c_str()));
  for (int i = 2; i < argc; ++i) args.push_back(argv[i]);
  args.push_back(nullptr);
  ::execv(target.c_str(), args.data());

  if (errno == ENOENT) {
    std::fprintf(stderr, "ddsnav: unknown command '%s'\n\n", command.c_str());
    return usage(dir, stderr);
  }
  std::fprintf(stderr, "ddsnav: cannot run %s: %s\n", target.c_str(), std::strerror(errno));
  return 127;
}
