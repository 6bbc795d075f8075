// DDS Security credentials for ddsnav: one directory holds a certificate authority, one identity per
// component name and the signed governance and permissions documents that both vendors' builtin plugins
// (PKI-DH authentication, Access-Permissions, AES-GCM-GMAC) read. No DDS header here; OpenSSL only.
//
//   security::initDirectory("keys", {.grants = security::stockGrants()});  // `ddsnav security init keys`
//   security::Credentials c = security::credentialsFor("keys", "mapper");  // checks every file, or throws
//   // c.identity_certificate, c.permissions, ... are absolute paths handed to the vendor as file: URIs
//
// Layout of a directory (docs/security.md):
//   ca.pem, ca.key.pem                       the CA: signs identities and both documents (identity CA = permissions CA)
//   governance.xml, governance.p7s           domain rules for all: authentication required, everything encrypted
//   identities/NAME/cert.pem, key.pem        one identity per component name (subject CN=NAME or CN=NAME.N)
//   identities/NAME/cert-cyclonedds.pem      the same identity's certificate for Cyclone DDS (same key)
//   identities/NAME/permissions.xml, .p7s    what NAME may publish and subscribe
#pragma once

#include <chrono>
#include <stdexcept>
#include <string>
#include <vector>

namespace ddsnav::security {

// Every error: names the file (or directory) and what is wrong with it.
class SecurityError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What one identity may do. Topic names may use DDS Security wildcards (fnmatch: *, ?, [...]).
struct Grant {
  std::string name;                    // identity (component) name: the certificate's CN
  std::vector<std::string> publish;
  std::vector<std::string> subscribe;
};

// The stock component names and the topics each publishes and subscribes, made from the runtime's topic
// table (runtime::stockTopics()), plus the tools' wildcards and the bus's own plumbing topics that every
// participant needs. Defined in the library ddsnav_security_grants (it links the runtime).
const std::vector<Grant>& stockGrants();

using Clock = std::chrono::system_clock;

struct Validity {
  Clock::time_point not_before;
  Clock::time_point not_after;
  // From now (less a minute of clock skew) for `days`.
  static Validity fromNow(int days);
};

// DDS domain ids the governance and every grant cover. Cyclone's access-control parser refuses ids above
// 230 (the RTPS port mapping alone would allow 232), so secured participants live on 0..230.
inline constexpr int kMinDomain = 0;
inline constexpr int kMaxDomain = 230;
inline constexpr int kMaxValidityDays = 36500;

struct InitOptions {
  int valid_days = 365;                       // identities and permissions; the CA gets 10 years more
  std::vector<Grant> grants;                  // one identity each: e.g. stockGrants()
  bool overwrite = false;                     // false: refuse a directory that already holds a CA
};

// Creates the CA, the governance document and one identity per grant. Throws SecurityError.
void initDirectory(const std::string& dir, const InitOptions& options);

// Adds (or replaces) one identity in an existing directory, signed by its CA: tests use it for identities
// with few topics or already expired.
void addIdentity(const std::string& dir, const Grant& grant, const Validity& validity);

// Absolute paths of one identity's files.
struct Credentials {
  std::string identity_ca;           // PEM certificate of the CA that signed the identity
  std::string identity_certificate;  // PEM
  std::string private_key;           // PEM, unencrypted
  std::string permissions_ca;        // PEM certificate of the CA that signed both documents
  std::string governance;            // S/MIME signed XML
  std::string permissions;           // S/MIME signed XML
};

// The files of `identity` in `dir`, checked: every file present and parseable, certificates within their
// validity, the identity certificate issued by the identity CA and matching its key, both documents
// signed by the permissions CA and well-formed, a grant for the identity's subject that is valid now.
// Throws SecurityError naming the first file that fails.
// `vendor` ("fastdds" | "cyclonedds"): each identity has a certificate per vendor (cert.pem for Fast DDS,
// cert-cyclonedds.pem for Cyclone; same key, subjects CN=NAME or CN=NAME.N), so that Cyclone starts every
// mixed-vendor handshake: the only order in which Fast DDS 2.9 and Cyclone DDS 0.10 agree on a key
// (docs/security.md).
Credentials credentialsFor(const std::string& dir, const std::string& identity, const std::string& vendor = "fastdds");

// The same checks on explicit paths.
void checkCredentials(const Credentials& credentials, const std::string& identity);

// The content of an S/MIME document after checking its signature against `ca_file`.
std::string verifiedDocument(const std::string& smime_file, const std::string& ca_file);

}  // namespace ddsnav::security
