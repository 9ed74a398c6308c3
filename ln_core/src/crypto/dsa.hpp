// DSA signatures with SHA-1 ("DSS1"), in the key files LN 2.9 reads and
// writes: the private key as a traditional PEM file ("BEGIN DSA PRIVATE
// KEY", mode 0600), the public key as one OpenSSH line ("ssh-dss BASE64
// [comment]"). Signatures are DER-encoded (r, s) pairs, as LN 2.9 makes
// them, so either side verifies what the other signed. The work is done by
// OpenSSL's libcrypto through its EVP interface; this file only converts
// between its keys and those two file formats.
//
// Every function returns 0 or a negative LNE_* code:
//   -LNE_INVALID_DSA_SIGNATURE  the signature does not verify (also when it
//                               is not a well-formed DER signature at all)
//   -LNE_CHECK_ERRNO            a file cannot be read or written (errno says
//                               why), or a key is not a DSA key in the
//                               expected format (errno = EINVAL)
//   -LNE_INVALID_PARAMETER      a required argument is missing
//   -LNE_INTERNAL_ERROR         libcrypto failed for another reason
// `detail` (optional) receives a sentence that names the file and the cause.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace ln::crypto {

/// Signs `message` with the private key in `pem_private_key_file`.
int dsa_sign(const std::string& pem_private_key_file, std::string_view message, std::string& signature,
             std::string* detail = nullptr);

/// Verifies against the OpenSSH public key in `openssh_public_key_file`.
int dsa_verify_with_key_file(const std::string& openssh_public_key_file, std::string_view message,
                             std::string_view signature, std::string* detail = nullptr);

/// Verifies against an OpenSSH public key given as text ("ssh-dss BASE64 ...").
int dsa_verify_with_key_text(std::string_view openssh_public_key, std::string_view message, std::string_view signature,
                             std::string* detail = nullptr);

/// Generates a 1024-bit DSA key (160-bit q, as LN 2.9's keys) and writes
/// both files; the private one with mode 0600. A file that exists is
/// replaced (the new contents appear at once, never half-written).
int dsa_generate_key_pair(const std::string& pem_private_key_file, const std::string& openssh_public_key_file,
                          std::string* detail = nullptr);

}  // namespace ln::crypto
