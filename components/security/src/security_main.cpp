// `ddsnav security init DIR`: a CA, one identity per stock component, signed governance and permissions.
// `ddsnav security check DIR NAME`: the checks a participant runs before it starts, on one identity.
#include <ddsnav/security/security.hpp>

#include <CLI/CLI.hpp>

#include <cstdio>

int main(int argc, char** argv) {
  using namespace ddsnav;
  CLI::App app{"ddsnav security: DDS Security credentials (docs/security.md)"};
  app.require_subcommand(1);
  std::string dir, identity;
  security::InitOptions init{.grants = security::stockGrants()};
  auto* init_cmd = app.add_subcommand("init", "create a CA, identities, governance and permissions in DIR");
  init_cmd->add_option("DIR", dir, "directory to create")->required();
  init_cmd->add_option("--days", init.valid_days, "validity of identities and permissions, days")
      ->check(CLI::Range(1, security::kMaxValidityDays));
  init_cmd->add_flag("--force", init.overwrite, "replace an existing CA and every identity in DIR");
  auto* check_cmd = app.add_subcommand("check", "check one identity's files as a participant would");
  check_cmd->add_option("DIR", dir, "security directory")->required();
  check_cmd->add_option("NAME", identity, "identity (component) name")->required();
  CLI11_PARSE(app, argc, argv);
  try {
    if (*init_cmd) {
      security::initDirectory(dir, init);
      std::printf("security: created a CA and %zu identities in %s (valid %d days)\n", init.grants.size(), dir.c_str(),
                  init.valid_days);
    } else {
      security::Credentials c = security::credentialsFor(dir, identity);
      std::printf("security: identity %s is valid (%s)\n", identity.c_str(), c.identity_certificate.c_str());
    }
  } catch (const security::SecurityError& e) {
    std::fprintf(stderr, "ddsnav security: %s\n", e.what());
    return 1;
  }
  return 0;
}
