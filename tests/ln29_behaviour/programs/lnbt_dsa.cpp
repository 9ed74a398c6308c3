// DSA probe of the LN 2.9 behaviour tests (ln_dsa_dss1_*, C and C++ API),
// written as for LN 2.9; compiled unchanged against LN 2.9 and ln_core.
// Needs no manager.
//
// usage: lnbt_dsa MODE ARGS
//   gen PEM PUB                 generate a key pair: "gen <LNE_NAME>"
//   sign PEM MESSAGE            "sig <hex>" or "sign <LNE_NAME>"
//   verify PUB MESSAGE HEX      ln_dsa_dss1_verify_message_signature and the
//                               _memkey variant (key read from PUB): "verify
//                               <LNE_NAME> memkey <LNE_NAME>", then the C++
//                               wrapper's answer: "cxx true|false|throws"
//   errors DIR                  bad input: one line per case, "<case> <LNE_NAME>"
#include <ln/ln.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "lnbt_errors.h"

namespace {

using lnbt::error_name;

std::string to_hex(const uint8_t* data, unsigned int length) {
  std::string hex;
  char digits[3];
  for (unsigned int i = 0; i < length; ++i) {
    std::snprintf(digits, sizeof digits, "%02x", data[i]);
    hex += digits;
  }
  return hex;
}

std::string from_hex(const std::string& hex) {
  std::string bytes;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    bytes += static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16));
  return bytes;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

const uint8_t* bytes(const std::string& text) { return reinterpret_cast<const uint8_t*>(text.data()); }

int verify_file(const std::string& pub, const std::string& message, const std::string& signature) {
  return ln_dsa_dss1_verify_message_signature(pub.c_str(), bytes(message), message.size(), bytes(signature),
                                              signature.size());
}

int verify_text(const std::string& key, const std::string& message, const std::string& signature) {
  return ln_dsa_dss1_verify_message_signature_memkey(key.c_str(), bytes(message), message.size(), bytes(signature),
                                                     signature.size());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: lnbt_dsa MODE ARGS\n");
    return 2;
  }
  const std::string mode = argv[1];
  auto arg = [&](int i) -> std::string { return i < argc ? argv[i] : ""; };
  if (mode == "gen") {
    std::printf("gen %s\n", error_name(ln_dsa_dss1_generate_key_pair(arg(2).c_str(), arg(3).c_str())).c_str());
  } else if (mode == "sign") {
    uint8_t* signature = nullptr;
    unsigned int length = 0;
    const std::string message = arg(3);
    const int ret = ln_dsa_dss1_sign_message(arg(2).c_str(), bytes(message), message.size(), &signature, &length);
    if (ret == 0) {
      std::printf("sig %s\n", to_hex(signature, length).c_str());
      std::free(signature);
    } else {
      std::printf("sign %s\n", error_name(ret).c_str());
    }
  } else if (mode == "verify") {
    const std::string signature = from_hex(arg(4));
    std::printf("verify %s memkey %s\n", error_name(verify_file(arg(2), arg(3), signature)).c_str(),
                error_name(verify_text(read_text(arg(2)), arg(3), signature)).c_str());
    try {
      std::printf("cxx %s\n", ln::dsa_dss1_verify_message_signature(arg(2), arg(3), signature) ? "true" : "false");
    } catch (const std::runtime_error&) {
      std::printf("cxx throws\n");
    }
  } else if (mode == "errors") {
    const std::string dir = arg(2);
    const std::string pem = dir + "/key.pem", pub = dir + "/key.pub";
    ln_dsa_dss1_generate_key_pair(pem.c_str(), pub.c_str());
    uint8_t* signature = nullptr;
    unsigned int length = 0;
    const std::string message = "errors";
    std::printf("sign_missing_file %s\n",
                error_name(ln_dsa_dss1_sign_message((dir + "/none.pem").c_str(), bytes(message), message.size(),
                                                    &signature, &length))
                    .c_str());
    std::printf(
        "sign_with_public_key %s\n",
        error_name(ln_dsa_dss1_sign_message(pub.c_str(), bytes(message), message.size(), &signature, &length)).c_str());
    ln_dsa_dss1_sign_message(pem.c_str(), bytes(message), message.size(), &signature, &length);
    const std::string good(reinterpret_cast<const char*>(signature), length);
    std::free(signature);
    std::printf("verify_missing_file %s\n", error_name(verify_file(dir + "/none.pub", message, good)).c_str());
    std::printf("verify_other_message %s\n", error_name(verify_file(pub, "other", good)).c_str());
    std::string flipped = good;
    flipped[8] = static_cast<char>(flipped[8] ^ 0x40);
    std::printf("verify_flipped_bit %s\n", error_name(verify_file(pub, message, flipped)).c_str());
    std::printf("memkey_rsa %s\n",
                error_name(verify_text("ssh-rsa AAAAB3NzaC1yc2EAAAADAQABAAAAgQC", message, good)).c_str());
    std::printf("memkey_with_comment %s\n",
                error_name(verify_text(read_text(pub) + " me@host", message, good)).c_str());
    try {
      ln::dsa_dss1_sign_message(dir + "/none.pem", message);
      std::printf("cxx_sign_missing_file returns\n");
    } catch (const std::runtime_error&) {
      std::printf("cxx_sign_missing_file throws\n");
    }
  } else {
    std::fprintf(stderr, "lnbt_dsa: unknown mode '%s'\n", mode.c_str());
    return 2;
  }
  return 0;
}
