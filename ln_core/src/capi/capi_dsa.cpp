// ln.h: the DSA signature helpers (crypto/dsa.hpp does the work).
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "client/c_api.hpp"
#include "crypto/dsa.hpp"

namespace {

std::string_view bytes(const uint8_t* data, unsigned int length) {
  return {reinterpret_cast<const char*>(data), length};
}

}  // namespace

extern "C" {

int ln_dsa_dss1_sign_message(const char* pem_private_key_filename, const uint8_t* message, unsigned int message_len,
                             uint8_t** signature_out, unsigned int* signature_out_len) {
  if (pem_private_key_filename == nullptr || (message == nullptr && message_len > 0) || signature_out == nullptr ||
      signature_out_len == nullptr)
    return -LNE_INVALID_PARAMETER;
  std::string signature;
  const int ret = ln::crypto::dsa_sign(pem_private_key_filename, bytes(message, message_len), signature);
  if (ret != 0) return ret;
  auto* copy = static_cast<uint8_t*>(std::malloc(signature.size()));
  if (copy == nullptr) return -LNE_NO_MEM;
  std::memcpy(copy, signature.data(), signature.size());
  *signature_out = copy;
  *signature_out_len = static_cast<unsigned int>(signature.size());
  return 0;
}

int ln_dsa_dss1_verify_message_signature(const char* openssh_public_key_filename, const uint8_t* message,
                                         unsigned int message_len, const uint8_t* signature,
                                         unsigned int signature_len) {
  if (openssh_public_key_filename == nullptr || (message == nullptr && message_len > 0) ||
      (signature == nullptr && signature_len > 0))
    return -LNE_INVALID_PARAMETER;
  return ln::crypto::dsa_verify_with_key_file(openssh_public_key_filename, bytes(message, message_len),
                                              bytes(signature, signature_len));
}

int ln_dsa_dss1_verify_message_signature_memkey(const char* openssh_public_key_contents, const uint8_t* message,
                                                unsigned int message_len, const uint8_t* signature,
                                                unsigned int signature_len) {
  if (openssh_public_key_contents == nullptr || (message == nullptr && message_len > 0) ||
      (signature == nullptr && signature_len > 0))
    return -LNE_INVALID_PARAMETER;
  return ln::crypto::dsa_verify_with_key_text(openssh_public_key_contents, bytes(message, message_len),
                                              bytes(signature, signature_len));
}

int ln_dsa_dss1_generate_key_pair(const char* pem_private_key_filename, const char* openssh_public_key_filename) {
  if (pem_private_key_filename == nullptr || openssh_public_key_filename == nullptr) return -LNE_INVALID_PARAMETER;
  return ln::crypto::dsa_generate_key_pair(pem_private_key_filename, openssh_public_key_filename);
}

}  // extern "C"
