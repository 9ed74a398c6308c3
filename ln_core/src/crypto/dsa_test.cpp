#include "crypto/dsa.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#define NO_CPP_WRAPPER
#include <ln/ln.h>

#include "testing/temp_dir.hpp"

namespace ln::crypto {
namespace {

// A key pair made by LN 2.9's ln_dsa_dss1_generate_key_pair() and its
// signature of kLn29Message, made by LN 2.9's ln_dsa_dss1_sign_message().
constexpr const char* kLn29PublicKey =
    "ssh-dss AAAAB3NzaC1kc3MAAACBAOadRSGcODGBFFWUahn2zkBK/SmOod6zLtY8k8nnhj4TMQlpuJRqAS/6O+xU+kDldql9ppCrTJZwkfS0+"
    "wLiC5YYTyNCiJNDl+O/F9AoR+UQUD8kW5ZRJvvew1aJpad9F/FrhLadcLY/yLlqGp/IntWp3Ar35xMmOMJXYMG/9XR5AAAAFQDsJxK8KafW8RA8"
    "gJ8vvcQKXLNO/QAAAIBbleg3sAOJcqyyG+Z1gbgOVr9FVTgi15/XwYF3R7IXMZNuKnNPmqoqby8TlC2OfYZC+TAf1Y1HqE9jHAITkECfFKdIM2Y"
    "z1mJ95a99Fd2vw0NVIW4kq9eQuY2PHyW3+1tQol2rmZmGZBwe9rAZah9Tk6IaPe2qhl0Lo3nljQ5aYAAAAIAwxPM6EiGIj3h5eyxBMvm6h8Zczn"
    "+d+hFMUwqbEYJSNflfZgqWVJzZM/WlPlEMzcsymnGlElHC6FOstCsidvIATN/t5tWp0p2PGu32noVGjuhvcS6FhkD0tMSx5PQ7YeCHjMCzk1HNN"
    "fTSRVabKNCu4PD0BosGXaYSbnPyXGlv5Q==\n";
constexpr const char* kLn29PrivateKey =
    "-----BEGIN DSA PRIVATE KEY-----\n"
    "MIIBugIBAAKBgQDmnUUhnDgxgRRVlGoZ9s5ASv0pjqHesy7WPJPJ54Y+EzEJabiU\n"
    "agEv+jvsVPpA5XapfaaQq0yWcJH0tPsC4guWGE8jQoiTQ5fjvxfQKEflEFA/JFuW\n"
    "USb73sNWiaWnfRfxa4S2nXC2P8i5ahqfyJ7VqdwK9+cTJjjCV2DBv/V0eQIVAOwn\n"
    "Erwpp9bxEDyAny+9xApcs079AoGAW5XoN7ADiXKsshvmdYG4Dla/RVU4Itef18GB\n"
    "d0eyFzGTbipzT5qqKm8vE5Qtjn2GQvkwH9WNR6hPYxwCE5BAnxSnSDNmM9ZifeWv\n"
    "fRXdr8NDVSFuJKvXkLmNjx8lt/tbUKJdq5mZhmQcHvawGWofU5OiGj3tqoZdC6N5\n"
    "5Y0OWmACgYAwxPM6EiGIj3h5eyxBMvm6h8Zczn+d+hFMUwqbEYJSNflfZgqWVJzZ\n"
    "M/WlPlEMzcsymnGlElHC6FOstCsidvIATN/t5tWp0p2PGu32noVGjuhvcS6FhkD0\n"
    "tMSx5PQ7YeCHjMCzk1HNNfTSRVabKNCu4PD0BosGXaYSbnPyXGlv5QIUZ+kQG2YY\n"
    "DRrPdOVoOBlgjqgWJPo=\n"
    "-----END DSA PRIVATE KEY-----\n";
constexpr const char* kLn29Message = "message signed by LN 2.9";
constexpr const char* kLn29SignatureHex =
    "302e021500da203a902269841af43b4d97f9272314fe0e9dbe021500c1ca31277a79a918b7b061e2a0ab0b15f2e49aae";

std::string from_hex(const std::string& hex) {
  std::string out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    out += static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16));
  return out;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

class DsaTest : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return dir_.path() + "/" + name; }
  void write(const std::string& name, const std::string& text) const { dir_.write(name, text); }

  test::TempDir dir_{"ln_dsa_test"};
};

TEST_F(DsaTest, VerifiesWhatLn29Signed) {
  const std::string signature = from_hex(kLn29SignatureHex);
  EXPECT_EQ(dsa_verify_with_key_text(kLn29PublicKey, kLn29Message, signature), 0);
  EXPECT_EQ(dsa_verify_with_key_text(kLn29PublicKey, "another message", signature), -LNE_INVALID_DSA_SIGNATURE);
}

TEST_F(DsaTest, SignsWithLn29sPrivateKey) {
  write("ln29.pem", kLn29PrivateKey);
  std::string signature;
  ASSERT_EQ(dsa_sign(path("ln29.pem"), "hello", signature), 0);
  EXPECT_EQ(dsa_verify_with_key_text(kLn29PublicKey, "hello", signature), 0);
}

TEST_F(DsaTest, GeneratedKeysHaveLn29sFileFormats) {
  ASSERT_EQ(dsa_generate_key_pair(path("k.pem"), path("k.pub")), 0);
  const std::string private_text = read_text(path("k.pem"));
  const std::string public_text = read_text(path("k.pub"));
  EXPECT_EQ(private_text.rfind("-----BEGIN DSA PRIVATE KEY-----\n", 0), 0u) << private_text;
  EXPECT_EQ(public_text.rfind("ssh-dss AAAAB3NzaC1kc3M", 0), 0u) << public_text;
  EXPECT_EQ(public_text.back(), '\n');
  EXPECT_EQ(std::count(public_text.begin(), public_text.end(), '\n'), 1);
  struct stat st {};
  ASSERT_EQ(::stat(path("k.pem").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);

  std::string signature;
  ASSERT_EQ(dsa_sign(path("k.pem"), "payload", signature), 0);
  EXPECT_EQ(dsa_verify_with_key_file(path("k.pub"), "payload", signature), 0);
  EXPECT_EQ(dsa_verify_with_key_text(public_text + " ignored comment", "payload", signature), 0);
  EXPECT_EQ(dsa_verify_with_key_file(path("k.pub"), "payloaD", signature), -LNE_INVALID_DSA_SIGNATURE);
  EXPECT_EQ(dsa_verify_with_key_text(kLn29PublicKey, "payload", signature), -LNE_INVALID_DSA_SIGNATURE);

  std::string empty_signature;
  ASSERT_EQ(dsa_sign(path("k.pem"), "", empty_signature), 0);
  EXPECT_EQ(dsa_verify_with_key_file(path("k.pub"), "", empty_signature), 0);
}

TEST_F(DsaTest, MalformedSignaturesAreInvalidNotErrors) {
  const std::string signature = from_hex(kLn29SignatureHex);
  std::string flipped = signature;
  flipped[10] = static_cast<char>(flipped[10] ^ 1);
  for (const std::string& bad : {std::string(), signature.substr(0, 1), signature.substr(0, signature.size() - 1),
                                 flipped, signature + std::string(5, '\0'), std::string(200, 'x')})
    EXPECT_EQ(dsa_verify_with_key_text(kLn29PublicKey, kLn29Message, bad), -LNE_INVALID_DSA_SIGNATURE) << bad.size();
}

TEST_F(DsaTest, BadKeysAreRefusedWithEinval) {
  const std::string signature = from_hex(kLn29SignatureHex);
  const std::string key = kLn29PublicKey;
  for (const std::string& bad :
       {std::string(), std::string("garbage"), std::string("ssh-rsa AAAAB3NzaC1yc2EAAAADAQABAAAAgQC"),
        std::string("ssh-dss"), std::string("ssh-dss !!!!"), key.substr(0, 100), key.substr(0, 400) + "=",
        std::string("ssh-dss AAAAB3NzaC1yc2EAAAADAQABAAAAgQC=")}) {
    std::string detail;
    errno = 0;
    EXPECT_EQ(dsa_verify_with_key_text(bad, kLn29Message, signature, &detail), -LNE_CHECK_ERRNO) << bad;
    EXPECT_EQ(errno, EINVAL) << bad;
    EXPECT_NE(detail.find("given public key"), std::string::npos) << detail;
  }
  write("not_a_key.pem", kLn29PublicKey);
  std::string out;
  std::string detail;
  EXPECT_EQ(dsa_sign(path("not_a_key.pem"), "x", out, &detail), -LNE_CHECK_ERRNO);
  EXPECT_EQ(errno, EINVAL);
  EXPECT_NE(detail.find("not_a_key.pem"), std::string::npos) << detail;
}

TEST_F(DsaTest, MissingFilesAreErrnoErrorsNamingTheFile) {
  std::string out;
  std::string detail;
  EXPECT_EQ(dsa_sign(path("missing.pem"), "x", out, &detail), -LNE_CHECK_ERRNO);
  EXPECT_EQ(errno, ENOENT);
  EXPECT_NE(detail.find("missing.pem"), std::string::npos) << detail;
  EXPECT_EQ(dsa_verify_with_key_file(path("missing.pub"), "x", "y"), -LNE_CHECK_ERRNO);
  EXPECT_EQ(errno, ENOENT);
  EXPECT_EQ(dsa_generate_key_pair(path("no/such/dir/k.pem"), path("k.pub")), -LNE_CHECK_ERRNO);
  EXPECT_EQ(errno, ENOENT);
  EXPECT_NE(::access(path("k.pub").c_str(), F_OK), 0) << "nothing is written when the first file fails";
}

}  // namespace
}  // namespace ln::crypto
