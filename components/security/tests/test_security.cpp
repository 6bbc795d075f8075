// The credentials directory: what `ddsnav security init` writes passes the checks a participant runs, and
// each kind of bad input is refused with a message naming the file.
#include <ddsnav/runtime/topics.hpp>
#include <ddsnav/security/security.hpp>

#include <gtest/gtest.h>
#include <openssl/bio.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/sha.h>
#include <openssl/x509.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

using namespace ddsnav;
namespace fs = std::filesystem;

namespace {

class SecurityDir : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("ddsnav_security_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    security::initDirectory(dir_.string(), {.grants = security::stockGrants()});
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static fs::path dir_;
};
fs::path SecurityDir::dir_;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void spit(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// Signs `text` with the directory's CA, the way the library does (so only the content is wrong).
std::string signWithCa(const fs::path& dir, const std::string& text) {
  BIO* cert_bio = BIO_new_file((dir / "ca.pem").c_str(), "r");
  BIO* key_bio = BIO_new_file((dir / "ca.key.pem").c_str(), "r");
  X509* cert = PEM_read_bio_X509(cert_bio, nullptr, nullptr, nullptr);
  EVP_PKEY* key = PEM_read_bio_PrivateKey(key_bio, nullptr, nullptr, nullptr);
  const int flags = PKCS7_DETACHED | PKCS7_TEXT | PKCS7_STREAM;
  BIO* in = BIO_new_mem_buf(text.data(), static_cast<int>(text.size()));
  PKCS7* p7 = PKCS7_sign(cert, key, nullptr, in, flags);
  BIO* again = BIO_new_mem_buf(text.data(), static_cast<int>(text.size()));
  BIO* out = BIO_new(BIO_s_mem());
  SMIME_write_PKCS7(out, p7, again, flags);
  char* data = nullptr;
  long n = BIO_get_mem_data(out, &data);
  std::string signed_text(data, static_cast<std::size_t>(n));
  for (BIO* b : {cert_bio, key_bio, in, again, out}) BIO_free(b);
  PKCS7_free(p7);
  X509_free(cert);
  EVP_PKEY_free(key);
  return signed_text;
}

// Runs credentialsFor and returns the error text ("" when it passed).
std::string errorOf(const fs::path& dir, const std::string& identity) {
  try {
    security::credentialsFor(dir.string(), identity);
    return "";
  } catch (const security::SecurityError& e) {
    return e.what();
  }
}

}  // namespace

TEST_F(SecurityDir, EveryStockIdentityPassesTheChecks) {
  for (const security::Grant& g : security::stockGrants()) {
    security::Credentials c = security::credentialsFor(dir_.string(), g.name);
    EXPECT_EQ(c.identity_certificate, (dir_ / "identities" / g.name / "cert.pem").string());
    EXPECT_TRUE(fs::path(c.governance).is_absolute());
  }
  EXPECT_EQ(fs::status(dir_ / "ca.key.pem").permissions() & fs::perms::others_read, fs::perms::none);
}

TEST_F(SecurityDir, PermissionsGrantExactlyTheTableTopicsAndDenyTheRest) {
  const std::string perception =
      security::verifiedDocument((dir_ / "identities/perception/permissions.p7s").string(), (dir_ / "ca.pem").string());
  EXPECT_NE(perception.find("<subject_name>CN=perception</subject_name>"), std::string::npos);
  EXPECT_NE(perception.find("<publish><topics><topic>perception/obstacles</topic>"), std::string::npos);
  EXPECT_EQ(perception.find("control/cmd_vel"), std::string::npos);
  EXPECT_NE(perception.find("<default>DENY</default>"), std::string::npos);
  const std::string governance = security::verifiedDocument((dir_ / "governance.p7s").string(), (dir_ / "ca.pem").string());
  EXPECT_NE(governance.find("<allow_unauthenticated_participants>false"), std::string::npos);
  EXPECT_NE(governance.find("<data_protection_kind>ENCRYPT"), std::string::npos);
}

// The grants are the topic table read per component: every (component, topic, direction) the table lists
// is granted, and nothing a stock component has is missing from the table (bar the bus's own topics).
TEST(StockGrants, AreTheTopicTableReadPerComponent) {
  auto grantOf = [](const std::string& name) -> const security::Grant& {
    for (const auto& g : security::stockGrants())
      if (g.name == name) return g;
    throw std::runtime_error("no grant for " + name);
  };
  auto has = [](const std::vector<std::string>& topics, const std::string& t) {
    return std::find(topics.begin(), topics.end(), t) != topics.end();
  };
  for (const std::string& component : runtime::stockComponents()) {
    const security::Grant& g = grantOf(component);
    for (const auto& row : runtime::stockTopics()) {
      EXPECT_EQ(has(g.publish, row.name), runtime::topicUseError(component, row.name, runtime::TopicUse::Publish).empty())
          << component << " publish " << row.name;
      EXPECT_EQ(has(g.subscribe, row.name), runtime::topicUseError(component, row.name, runtime::TopicUse::Subscribe).empty())
          << component << " subscribe " << row.name;
    }
    for (const auto* list : {&g.publish, &g.subscribe})
      for (const auto& t : *list)
        EXPECT_TRUE(t == "ddsnav_internal/*" || runtime::findStockTopic(t) != nullptr) << component << ": " << t;
  }
  // What the demo needs, spelled out once (the secured demo test runs it for real).
  EXPECT_TRUE(has(grantOf("sim").publish, "system/clock"));
  EXPECT_TRUE(has(grantOf("tracker").subscribe, "map/octomap"));
  EXPECT_TRUE(has(grantOf("monitor").subscribe, "planning/request"));
  EXPECT_TRUE(has(grantOf("perception").publish, "system/status"));
  EXPECT_FALSE(has(grantOf("perception").publish, "control/cmd_vel"));
  EXPECT_TRUE(has(grantOf("record").subscribe, "*"));
  EXPECT_TRUE(has(grantOf("play").publish, "*"));
}

// A stock component opening a topic the table does not list for it is refused at start (Context), with
// the table named; a component of the user's own is not checked.
TEST(StockGrants, ATopicUseTheTableLacksIsAnError) {
  EXPECT_EQ(runtime::topicUseError("perception", "perception/obstacles", runtime::TopicUse::Publish), "");
  EXPECT_EQ(runtime::topicUseError("perception", "sensors/points", runtime::TopicUse::Subscribe), "");
  const std::string error = runtime::topicUseError("perception", "control/cmd_vel", runtime::TopicUse::Publish);
  EXPECT_NE(error.find("perception publishes 'control/cmd_vel'"), std::string::npos) << error;
  EXPECT_NE(error.find("components/runtime/src/topics.cpp"), std::string::npos) << error;
  EXPECT_NE(runtime::topicUseError("mapper", "mapper/debug", runtime::TopicUse::Publish).find("not in the stock topic table"),
            std::string::npos);
  EXPECT_EQ(runtime::topicUseError("closest_obstacle", "control/cmd_vel", runtime::TopicUse::Publish), "");
}

// The first byte of SHA-256 over the certificate subject's DER: what DDS Security makes the GUID from.
int subjectHashFirstByte(const std::string& pem_file) {
  BIO* bio = BIO_new_file(pem_file.c_str(), "r");
  X509* cert = PEM_read_bio_X509(bio, nullptr, nullptr, nullptr);
  BIO_free(bio);
  if (cert == nullptr) return -1;
  unsigned char* der = nullptr;
  const int size = i2d_X509_NAME(X509_get_subject_name(cert), &der);
  unsigned char digest[SHA256_DIGEST_LENGTH];
  SHA256(der, static_cast<std::size_t>(size), digest);
  OPENSSL_free(der);
  X509_free(cert);
  return digest[0];
}

// Every identity's Cyclone certificate hashes below every Fast DDS one (so Cyclone starts every mixed
// handshake); both are of the same key and granted the same topics.
TEST_F(SecurityDir, EachIdentityHasACertificatePerVendorOrderedForMixedHandshakes) {
  for (const security::Grant& g : security::stockGrants()) {
    const security::Credentials fast = security::credentialsFor(dir_.string(), g.name, "fastdds");
    const security::Credentials cyclone = security::credentialsFor(dir_.string(), g.name, "cyclonedds");
    EXPECT_EQ(fast.identity_certificate, (dir_ / "identities" / g.name / "cert.pem").string());
    EXPECT_EQ(cyclone.identity_certificate, (dir_ / "identities" / g.name / "cert-cyclonedds.pem").string());
    EXPECT_EQ(fast.private_key, cyclone.private_key);
    EXPECT_GE(subjectHashFirstByte(fast.identity_certificate), 0x80) << g.name;
    EXPECT_LT(subjectHashFirstByte(cyclone.identity_certificate), 0x80) << g.name;
  }
}

TEST_F(SecurityDir, ACertificateOfAnotherIdentityIsRefused) {
  security::addIdentity(dir_.string(), {"swapped", {"a"}, {}}, security::Validity::fromNow(1));
  fs::copy_file(dir_ / "identities/mapper/cert.pem", dir_ / "identities/swapped/cert.pem", fs::copy_options::overwrite_existing);
  const std::string error = errorOf(dir_, "swapped");
  EXPECT_NE(error.find("not identity 'swapped'"), std::string::npos) << error;
}

TEST_F(SecurityDir, ARefusedDirectoryIsNotOverwritten) {
  EXPECT_THROW(security::initDirectory(dir_.string(), {.grants = security::stockGrants()}), security::SecurityError);
}

TEST_F(SecurityDir, UnknownIdentityAndMissingFilesNameThePath) {
  EXPECT_NE(errorOf(dir_, "stranger").find("no identity 'stranger'"), std::string::npos);
  EXPECT_NE(errorOf(dir_ / "nowhere", "sim").find("does not exist"), std::string::npos);
  security::addIdentity(dir_.string(), {"nocert", {"a"}, {}}, security::Validity::fromNow(1));
  fs::remove(dir_ / "identities/nocert/cert.pem");
  const std::string error = errorOf(dir_, "nocert");
  EXPECT_NE(error.find("identities/nocert/cert.pem"), std::string::npos) << error;
  EXPECT_NE(error.find("cannot read"), std::string::npos) << error;
}

TEST_F(SecurityDir, AnExpiredCertificateIsRefused) {
  const auto now = security::Clock::now();
  security::addIdentity(dir_.string(), {"expired", {"a"}, {}},
                        {now - std::chrono::hours(48), now - std::chrono::hours(24)});
  const std::string error = errorOf(dir_, "expired");
  EXPECT_NE(error.find("identities/expired/cert.pem' has expired"), std::string::npos) << error;
}

TEST_F(SecurityDir, PermissionsSignedByAnotherCaAreRefused) {
  const fs::path other = dir_.string() + "_other";
  fs::remove_all(other);
  security::initDirectory(other.string(), {.grants = {{"mapper", {"map/octomap"}, {}}}});
  security::addIdentity(dir_.string(), {"foreign", {"a"}, {}}, security::Validity::fromNow(1));
  security::addIdentity(other.string(), {"foreign", {"*"}, {"*"}}, security::Validity::fromNow(1));
  fs::copy_file(other / "identities/foreign/permissions.p7s", dir_ / "identities/foreign/permissions.p7s",
                fs::copy_options::overwrite_existing);
  const std::string error = errorOf(dir_, "foreign");
  EXPECT_NE(error.find("identities/foreign/permissions.p7s': signature does not verify"), std::string::npos) << error;
  // An identity certificate from another CA is refused as well.
  fs::copy_file(other / "identities/foreign/cert.pem", dir_ / "identities/foreign/cert.pem", fs::copy_options::overwrite_existing);
  EXPECT_NE(errorOf(dir_, "foreign").find("is not issued by the identity CA"), std::string::npos);
  fs::remove_all(other);
}

TEST_F(SecurityDir, AGovernanceThatDoesNotParseIsRefused) {
  const fs::path copy = dir_.string() + "_badgov";
  fs::remove_all(copy);
  fs::copy(dir_, copy, fs::copy_options::recursive);
  spit(copy / "governance.p7s", signWithCa(copy, "<dds><domain_access_rules><domain_rule>"));
  std::string error = errorOf(copy, "sim");
  EXPECT_NE(error.find("governance.p7s' does not parse as XML"), std::string::npos) << error;
  // Altered after signing: the signature check catches it.
  std::string text = slurp(dir_ / "governance.p7s");
  text.replace(text.find("ENCRYPT"), 7, "NONE\n\n\n");
  spit(copy / "governance.p7s", text);
  error = errorOf(copy, "sim");
  EXPECT_NE(error.find("governance.p7s': signature does not verify"), std::string::npos) << error;
  fs::remove_all(copy);
}

TEST(Security, ValidityIsBounded) {
  EXPECT_THROW(security::Validity::fromNow(0), security::SecurityError);
  EXPECT_THROW(security::Validity::fromNow(security::kMaxValidityDays + 1), security::SecurityError);
  EXPECT_THROW(security::addIdentity("/tmp", {"Bad Name", {}, {}}, security::Validity::fromNow(1)), security::SecurityError);
}
