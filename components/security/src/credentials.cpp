// Creating and checking a ddsnav security directory with OpenSSL's libcrypto (keys, X.509, S/MIME).
#include <ddsnav/security/security.hpp>

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/rand.h>
#include <openssl/sha.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>
#include <tinyxml2.h>

#include <sys/stat.h>

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

namespace ddsnav::security {
namespace fs = std::filesystem;

namespace {

template <class T, void (*Free)(T*)>
struct Deleter {
  void operator()(T* p) const { Free(p); }
};
using Bio = std::unique_ptr<BIO, Deleter<BIO, BIO_free_all>>;
using Key = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;
using Cert = std::unique_ptr<X509, Deleter<X509, X509_free>>;
using Store = std::unique_ptr<X509_STORE, Deleter<X509_STORE, X509_STORE_free>>;
using StoreCtx = std::unique_ptr<X509_STORE_CTX, Deleter<X509_STORE_CTX, X509_STORE_CTX_free>>;
using Pkcs7 = std::unique_ptr<PKCS7, Deleter<PKCS7, PKCS7_free>>;

// OpenSSL's own reason for the last failure, for messages.
std::string opensslError() {
  unsigned long code = ERR_get_error();
  ERR_clear_error();
  if (code == 0) return "no detail from OpenSSL";
  char text[256];
  ERR_error_string_n(code, text, sizeof(text));
  return text;
}

std::string readFile(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SecurityError(what + " '" + path + "': cannot read the file (missing or not readable)");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void writeFile(const std::string& path, const std::string& text, bool secret = false) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw SecurityError("cannot write '" + path + "'");
  if (secret) ::chmod(path.c_str(), 0600);
}

Bio memoryBio(const std::string& text) { return Bio(BIO_new_mem_buf(text.data(), static_cast<int>(text.size()))); }

std::string bioText(BIO* bio) {
  char* data = nullptr;
  long n = BIO_get_mem_data(bio, &data);
  return std::string(data, static_cast<std::size_t>(n));
}

Cert loadCertificate(const std::string& path, const std::string& what) {
  std::string pem = readFile(path, what);
  Bio bio = memoryBio(pem);
  Cert cert(PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr));
  if (!cert) throw SecurityError(what + " '" + path + "': not a PEM X.509 certificate (" + opensslError() + ")");
  return cert;
}

Key loadKey(const std::string& path) {
  std::string pem = readFile(path, "private key");
  Bio bio = memoryBio(pem);
  Key key(PEM_read_bio_PrivateKey(bio.get(), nullptr, nullptr, nullptr));
  if (!key) throw SecurityError("private key '" + path + "': not an unencrypted PEM private key (" + opensslError() + ")");
  return key;
}

std::string utcText(Clock::time_point t) {
  std::time_t seconds = Clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%S", &tm);
  return text;
}

std::string asn1TimeText(const ASN1_TIME* t) {
  Bio bio(BIO_new(BIO_s_mem()));
  ASN1_TIME_print(bio.get(), t);
  return bioText(bio.get());
}

// A certificate must be valid now: the vendors refuse expired ones only at handshake time, silently.
void checkValidityNow(X509* cert, const std::string& path, const std::string& what) {
  if (X509_cmp_current_time(X509_get0_notBefore(cert)) > 0)
    throw SecurityError(what + " '" + path + "' is not valid yet: valid from " + asn1TimeText(X509_get0_notBefore(cert)));
  if (X509_cmp_current_time(X509_get0_notAfter(cert)) < 0)
    throw SecurityError(what + " '" + path + "' has expired: valid until " + asn1TimeText(X509_get0_notAfter(cert)));
}

Store storeWith(X509* ca) {
  Store store(X509_STORE_new());
  X509_STORE_add_cert(store.get(), ca);
  return store;
}

Key newKey() {
  Key key(EVP_EC_gen("P-256"));
  if (!key) throw SecurityError("cannot generate an EC P-256 key: " + opensslError());
  return key;
}

void addExtension(X509* cert, X509* issuer, int nid, const char* value) {
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, issuer, cert, nullptr, nullptr, 0);
  X509_EXTENSION* ext = X509V3_EXT_conf_nid(nullptr, &ctx, nid, value);
  if (ext == nullptr) throw SecurityError(std::string("cannot build certificate extension ") + value);
  X509_add_ext(cert, ext, -1);
  X509_EXTENSION_free(ext);
}

// issuer/issuer_key null: self-signed (the CA).
Cert newCertificate(const std::string& common_name, EVP_PKEY* key, X509* issuer, EVP_PKEY* issuer_key,
                    const Validity& validity, bool is_ca) {
  Cert cert(X509_new());
  X509_set_version(cert.get(), 2);
  unsigned char serial[16];
  RAND_bytes(serial, sizeof(serial));
  serial[0] &= 0x7f;  // positive
  BIGNUM* bn = BN_bin2bn(serial, sizeof(serial), nullptr);
  BN_to_ASN1_INTEGER(bn, X509_get_serialNumber(cert.get()));
  BN_free(bn);
  ASN1_TIME_set(X509_getm_notBefore(cert.get()), Clock::to_time_t(validity.not_before));
  ASN1_TIME_set(X509_getm_notAfter(cert.get()), Clock::to_time_t(validity.not_after));
  X509_set_pubkey(cert.get(), key);
  X509_NAME* name = X509_get_subject_name(cert.get());
  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_UTF8, reinterpret_cast<const unsigned char*>(common_name.c_str()), -1,
                             -1, 0);
  X509* signer = issuer != nullptr ? issuer : cert.get();
  X509_set_issuer_name(cert.get(), X509_get_subject_name(signer));
  if (is_ca) {
    addExtension(cert.get(), signer, NID_basic_constraints, "critical,CA:TRUE");
    // digitalSignature too: the CA signs the governance and permissions documents (S/MIME purpose check).
    addExtension(cert.get(), signer, NID_key_usage, "critical,keyCertSign,cRLSign,digitalSignature");
  } else {
    addExtension(cert.get(), signer, NID_basic_constraints, "CA:FALSE");
    addExtension(cert.get(), signer, NID_key_usage, "critical,digitalSignature,keyAgreement");
  }
  addExtension(cert.get(), signer, NID_subject_key_identifier, "hash");
  if (X509_sign(cert.get(), issuer_key != nullptr ? issuer_key : key, EVP_sha256()) == 0)
    throw SecurityError("cannot sign the certificate of " + common_name + ": " + opensslError());
  return cert;
}

std::string pemOf(X509* cert) {
  Bio bio(BIO_new(BIO_s_mem()));
  PEM_write_bio_X509(bio.get(), cert);
  return bioText(bio.get());
}

std::string pemOf(EVP_PKEY* key) {
  Bio bio(BIO_new(BIO_s_mem()));
  PEM_write_bio_PrivateKey(bio.get(), key, nullptr, nullptr, 0, nullptr, nullptr);
  return bioText(bio.get());
}

// Clear-signed S/MIME (text/plain content, detached signature) as the DDS Security plugins expect.
std::string smimeSign(const std::string& document, X509* ca, EVP_PKEY* ca_key) {
  const int flags = PKCS7_DETACHED | PKCS7_TEXT | PKCS7_STREAM;
  Bio in = memoryBio(document);
  Pkcs7 p7(PKCS7_sign(ca, ca_key, nullptr, in.get(), flags));
  if (!p7) throw SecurityError("cannot sign a document: " + opensslError());
  Bio out(BIO_new(BIO_s_mem()));
  Bio again = memoryBio(document);
  if (SMIME_write_PKCS7(out.get(), p7.get(), again.get(), flags) != 1)
    throw SecurityError("cannot write an S/MIME document: " + opensslError());
  return bioText(out.get());
}

std::string domainsXml(const std::string& indent) {
  return indent + "<domains><id_range><min>" + std::to_string(kMinDomain) + "</min><max>" + std::to_string(kMaxDomain) +
         "</max></id_range></domains>\n";
}

std::string xmlEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

constexpr const char* kXmlHeader =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
    "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_";

// Join only with a certificate from this CA; discovery, liveliness and data encrypted, RTPS messages signed.
std::string governanceXml() {
  std::string x = std::string(kXmlHeader) + "governance.xsd\">\n  <domain_access_rules>\n    <domain_rule>\n";
  x += domainsXml("      ");
  x += "      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>\n"
       "      <enable_join_access_control>true</enable_join_access_control>\n"
       "      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>\n"
       "      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>\n"
       "      <rtps_protection_kind>SIGN</rtps_protection_kind>\n"
       "      <topic_access_rules>\n        <topic_rule>\n"
       "          <topic_expression>*</topic_expression>\n"
       "          <enable_discovery_protection>true</enable_discovery_protection>\n"
       "          <enable_liveliness_protection>true</enable_liveliness_protection>\n"
       "          <enable_read_access_control>true</enable_read_access_control>\n"
       "          <enable_write_access_control>true</enable_write_access_control>\n"
       "          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>\n"
       "          <data_protection_kind>ENCRYPT</data_protection_kind>\n"
       "        </topic_rule>\n      </topic_access_rules>\n    </domain_rule>\n  </domain_access_rules>\n</dds>\n";
  return x;
}

std::string topicsXml(const char* element, const std::vector<std::string>& topics) {
  if (topics.empty()) return {};
  std::string x = std::string("        <") + element + "><topics>";
  for (const std::string& t : topics) x += "<topic>" + xmlEscape(t) + "</topic>";
  return x + "</topics></" + element + ">\n";
}

struct CaFiles {
  Cert cert;
  Key key;
};

// One grant per certificate subject of the identity (its Fast DDS and its Cyclone DDS certificate), the
// same rules in each.
std::string permissionsXml(const Grant& grant, const std::vector<std::string>& common_names, const Validity& validity) {
  std::string x = std::string(kXmlHeader) + "permissions.xsd\">\n  <permissions>\n";
  for (const std::string& cn : common_names) {
    x += "    <grant name=\"" + xmlEscape(cn) + "\">\n";
    x += "      <subject_name>CN=" + xmlEscape(cn) + "</subject_name>\n";
    x += "      <validity><not_before>" + utcText(validity.not_before) + "</not_before><not_after>" +
         utcText(validity.not_after) + "</not_after></validity>\n";
    x += "      <allow_rule>\n" + domainsXml("        ") + topicsXml("publish", grant.publish) +
         topicsXml("subscribe", grant.subscribe) + "      </allow_rule>\n";
    x += "      <default>DENY</default>\n    </grant>\n";
  }
  x += "  </permissions>\n</dds>\n";
  return x;
}

// Mixed vendors secured. DDS Security makes a participant's GUID prefix from its certificate: a 1 bit,
// then the first 47 bits of SHA-256 over the subject name's DER. Of two participants the one with the
// lower GUID starts the handshake, and the starter picks the key agreement: Fast DDS 2.9 always picks
// DH+MODP-2048-256 (it has no property to choose; later releases do) and sends its public key in a form
// Cyclone DDS 0.10 cannot decode ("Failed to convert octet sequence to ASN1 integer"), while Cyclone
// picks ECDH, which both do. So every identity gets a certificate per vendor over the same key, the
// subject's common name NAME or NAME.N with the first N that puts the hash's first byte below 0x80 for
// Cyclone and at or above it for Fast DDS: every Cyclone participant's GUID is then lower than every
// Fast DDS one's, and Cyclone starts every mixed handshake (docs/security.md, "Interoperability").
bool subjectHashIsLow(X509* cert) {
  unsigned char* der = nullptr;
  const int size = i2d_X509_NAME(X509_get_subject_name(cert), &der);
  if (size <= 0) throw SecurityError("cannot encode a certificate subject: " + opensslError());
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(der, static_cast<std::size_t>(size), digest);
  OPENSSL_free(der);
  return digest[0] < 0x80;
}

struct VendorCertificate {
  std::string common_name;
  Cert cert;
};

VendorCertificate certificateWithLowHash(bool low, const std::string& name, EVP_PKEY* key, const CaFiles& ca,
                                         const Validity& validity);

// Whether `cn` names identity `name`: NAME itself, or NAME.N (a certificate ground for one vendor).
bool commonNameOf(const std::string& cn, const std::string& name) {
  if (cn == name) return true;
  if (cn.size() <= name.size() + 1 || cn.compare(0, name.size(), name) != 0 || cn[name.size()] != '.') return false;
  return cn.find_first_not_of("0123456789", name.size() + 1) == std::string::npos;
}

std::string commonNameOfCertificate(X509* cert) {
  X509_NAME* name = X509_get_subject_name(cert);
  const int at = X509_NAME_get_index_by_NID(name, NID_commonName, -1);
  if (at < 0) return "";
  const unsigned char* text = nullptr;
  const int size = ASN1_STRING_to_UTF8(const_cast<unsigned char**>(&text), X509_NAME_ENTRY_get_data(X509_NAME_get_entry(name, at)));
  if (size < 0) return "";
  std::string cn(reinterpret_cast<const char*>(text), static_cast<std::size_t>(size));
  OPENSSL_free(const_cast<unsigned char*>(text));
  return cn;
}

void checkName(const std::string& name) {
  if (name.empty() || name.size() > 64 || name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_-") != std::string::npos)
    throw SecurityError("identity name '" + name + "': expected 1-64 characters of a-z, 0-9, '_' and '-'");
}

CaFiles loadCa(const std::string& dir) {
  CaFiles ca{loadCertificate(dir + "/ca.pem", "CA certificate"), loadKey(dir + "/ca.key.pem")};
  if (X509_check_private_key(ca.cert.get(), ca.key.get()) != 1)
    throw SecurityError("CA key '" + dir + "/ca.key.pem' does not belong to the CA certificate '" + dir + "/ca.pem'");
  return ca;
}

fs::path absoluteDir(const std::string& dir) {
  if (dir.empty()) throw SecurityError("security directory: empty path");
  return fs::absolute(dir).lexically_normal();
}

// Parses a permissions date: the spec's xs:dateTime, as both vendors read it (UTC, optional 'Z').
bool parseUtc(const char* text, std::time_t& out) {
  if (text == nullptr) return false;
  std::tm tm{};
  const char* end = strptime(text, "%Y-%m-%dT%H:%M:%S", &tm);
  if (end == nullptr || (*end != '\0' && std::string(end) != "Z")) return false;
  out = timegm(&tm);
  return true;
}

VendorCertificate certificateWithLowHash(bool low, const std::string& name, EVP_PKEY* key, const CaFiles& ca,
                                         const Validity& validity) {
  // Each try succeeds with probability 1/2; 64 failures in a row do not happen (2^-64).
  for (int n = 0; n < 64; ++n) {
    const std::string cn = n == 0 ? name : name + "." + std::to_string(n);
    Cert cert = newCertificate(cn, key, ca.cert.get(), ca.key.get(), validity, false);
    if (subjectHashIsLow(cert.get()) == low) return {cn, std::move(cert)};
  }
  throw SecurityError("no certificate subject for identity '" + name + "' hashes as needed (64 tries)");
}

}  // namespace

Validity Validity::fromNow(int days) {
  if (days < 1 || days > kMaxValidityDays)
    throw SecurityError("validity of " + std::to_string(days) + " days: expected 1.." + std::to_string(kMaxValidityDays));
  auto now = Clock::now();
  return {now - std::chrono::minutes(1), now + std::chrono::hours(24) * days};
}

void addIdentity(const std::string& dir_text, const Grant& grant, const Validity& validity) {
  checkName(grant.name);
  const fs::path dir = absoluteDir(dir_text);
  CaFiles ca = loadCa(dir);
  const fs::path id = dir / "identities" / grant.name;
  std::error_code ec;
  fs::create_directories(id, ec);
  if (ec) throw SecurityError("cannot create '" + id.string() + "': " + ec.message());
  Key key = newKey();
  VendorCertificate fastdds = certificateWithLowHash(false, grant.name, key.get(), ca, validity);
  VendorCertificate cyclone = certificateWithLowHash(true, grant.name, key.get(), ca, validity);
  writeFile(id / "key.pem", pemOf(key.get()), true);
  writeFile(id / "cert.pem", pemOf(fastdds.cert.get()));
  writeFile(id / "cert-cyclonedds.pem", pemOf(cyclone.cert.get()));
  const std::string permissions = permissionsXml(grant, {fastdds.common_name, cyclone.common_name}, validity);
  writeFile(id / "permissions.xml", permissions);
  writeFile(id / "permissions.p7s", smimeSign(permissions, ca.cert.get(), ca.key.get()));
}

void initDirectory(const std::string& dir_text, const InitOptions& options) {
  const fs::path dir = absoluteDir(dir_text);
  const Validity validity = Validity::fromNow(options.valid_days);
  if (fs::exists(dir / "ca.pem") && !options.overwrite)
    throw SecurityError("security directory '" + dir.string() + "' already holds a CA (ca.pem); refusing to replace it");
  for (const Grant& g : options.grants) checkName(g.name);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw SecurityError("cannot create security directory '" + dir.string() + "': " + ec.message());
  ::chmod(dir.c_str(), 0700);

  Key ca_key = newKey();
  const Validity ca_validity{validity.not_before, validity.not_after + std::chrono::hours(24) * 3650};
  Cert ca = newCertificate("ddsnav CA", ca_key.get(), nullptr, nullptr, ca_validity, true);
  writeFile(dir / "ca.key.pem", pemOf(ca_key.get()), true);
  writeFile(dir / "ca.pem", pemOf(ca.get()));
  const std::string governance = governanceXml();
  writeFile(dir / "governance.xml", governance);
  writeFile(dir / "governance.p7s", smimeSign(governance, ca.get(), ca_key.get()));
  for (const Grant& g : options.grants) addIdentity(dir, g, validity);
}

std::string verifiedDocument(const std::string& smime_file, const std::string& ca_file) {
  Cert ca = loadCertificate(ca_file, "permissions CA certificate");
  std::string text = readFile(smime_file, "signed document");
  Bio in = memoryBio(text);
  BIO* content_raw = nullptr;
  Pkcs7 p7(SMIME_read_PKCS7(in.get(), &content_raw));
  Bio content(content_raw);
  if (!p7) throw SecurityError("'" + smime_file + "': not an S/MIME signed document (" + opensslError() + ")");
  Store store = storeWith(ca.get());
  Bio out(BIO_new(BIO_s_mem()));
  if (PKCS7_verify(p7.get(), nullptr, store.get(), content.get(), out.get(), PKCS7_TEXT) != 1)
    throw SecurityError("'" + smime_file + "': signature does not verify against the permissions CA '" + ca_file +
                        "' (signed by another CA, or altered: " + opensslError() + ")");
  return bioText(out.get());
}

void checkCredentials(const Credentials& c, const std::string& identity) {
  Cert identity_ca = loadCertificate(c.identity_ca, "identity CA certificate");
  checkValidityNow(identity_ca.get(), c.identity_ca, "identity CA certificate");
  Cert permissions_ca = loadCertificate(c.permissions_ca, "permissions CA certificate");
  checkValidityNow(permissions_ca.get(), c.permissions_ca, "permissions CA certificate");

  Cert cert = loadCertificate(c.identity_certificate, "identity certificate");
  checkValidityNow(cert.get(), c.identity_certificate, "identity certificate");
  const std::string cn = commonNameOfCertificate(cert.get());
  if (!commonNameOf(cn, identity))
    throw SecurityError("identity certificate '" + c.identity_certificate + "' is for CN=" + cn + ", not identity '" + identity + "'");
  {
    Store store = storeWith(identity_ca.get());
    StoreCtx ctx(X509_STORE_CTX_new());
    X509_STORE_CTX_init(ctx.get(), store.get(), cert.get(), nullptr);
    if (X509_verify_cert(ctx.get()) != 1)
      throw SecurityError("identity certificate '" + c.identity_certificate + "' is not issued by the identity CA '" +
                          c.identity_ca + "': " + X509_verify_cert_error_string(X509_STORE_CTX_get_error(ctx.get())));
  }
  Key key = loadKey(c.private_key);
  if (X509_check_private_key(cert.get(), key.get()) != 1)
    throw SecurityError("private key '" + c.private_key + "' does not belong to the identity certificate '" +
                        c.identity_certificate + "'");

  const std::string governance = verifiedDocument(c.governance, c.permissions_ca);
  tinyxml2::XMLDocument gov;
  if (gov.Parse(governance.c_str(), governance.size()) != tinyxml2::XML_SUCCESS)
    throw SecurityError("governance '" + c.governance + "' does not parse as XML: " + gov.ErrorStr());
  const tinyxml2::XMLElement* rules = gov.RootElement() ? gov.RootElement()->FirstChildElement("domain_access_rules") : nullptr;
  if (rules == nullptr || rules->FirstChildElement("domain_rule") == nullptr)
    throw SecurityError("governance '" + c.governance + "': expected <dds><domain_access_rules><domain_rule>");

  const std::string permissions = verifiedDocument(c.permissions, c.permissions_ca);
  tinyxml2::XMLDocument perm;
  if (perm.Parse(permissions.c_str(), permissions.size()) != tinyxml2::XML_SUCCESS)
    throw SecurityError("permissions '" + c.permissions + "' do not parse as XML: " + perm.ErrorStr());
  const tinyxml2::XMLElement* grants = perm.RootElement() ? perm.RootElement()->FirstChildElement("permissions") : nullptr;
  if (grants == nullptr) throw SecurityError("permissions '" + c.permissions + "': expected <dds><permissions>");
  const std::string subject = "CN=" + cn;
  for (const auto* g = grants->FirstChildElement("grant"); g != nullptr; g = g->NextSiblingElement("grant")) {
    const auto* s = g->FirstChildElement("subject_name");
    if (s == nullptr || s->GetText() == nullptr || subject != s->GetText()) continue;
    const auto* validity = g->FirstChildElement("validity");
    std::time_t from = 0, until = 0;
    if (validity == nullptr || !parseUtc(validity->FirstChildElement("not_before") ? validity->FirstChildElement("not_before")->GetText() : nullptr, from) ||
        !parseUtc(validity->FirstChildElement("not_after") ? validity->FirstChildElement("not_after")->GetText() : nullptr, until))
      throw SecurityError("permissions '" + c.permissions + "': grant for " + subject +
                          " lacks a <validity> with not_before/not_after as YYYY-MM-DDTHH:MM:SS");
    const std::time_t now = std::time(nullptr);
    if (now < from || now > until)
      throw SecurityError("permissions '" + c.permissions + "': the grant for " + subject + " is valid only from " +
                          validity->FirstChildElement("not_before")->GetText() + " to " +
                          validity->FirstChildElement("not_after")->GetText() + " (UTC)");
    return;
  }
  throw SecurityError("permissions '" + c.permissions + "': no grant for subject " + subject);
}

Credentials credentialsFor(const std::string& dir_text, const std::string& identity, const std::string& vendor) {
  const fs::path dir = absoluteDir(dir_text);
  if (!fs::is_directory(dir)) throw SecurityError("security directory '" + dir.string() + "' does not exist");
  const fs::path id = dir / "identities" / identity;
  if (identity.empty() || !fs::is_directory(id))
    throw SecurityError("security directory '" + dir.string() + "' has no identity '" + identity + "' (expected " +
                        id.string() + "/; `ddsnav security init` creates one per component name)");
  // Cyclone's own certificate where the directory has one (made before it: the shared one, mixed pairs may fail).
  const fs::path cert = vendor == "cyclonedds" && fs::exists(id / "cert-cyclonedds.pem") ? id / "cert-cyclonedds.pem" : id / "cert.pem";
  Credentials c{(dir / "ca.pem").string(),           cert.string(),                    (id / "key.pem").string(),
                (dir / "ca.pem").string(),           (dir / "governance.p7s").string(), (id / "permissions.p7s").string()};
  checkCredentials(c, identity);
  return c;
}

}  // namespace ddsnav::security
