#include "crypto/dsa.hpp"

#include <fcntl.h>
#include <openssl/bio.h>
#include <openssl/bn.h>
#include <openssl/core_names.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/param_build.h>
#include <openssl/pem.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <vector>

#include "client/c_api.hpp"

namespace ln::crypto {
namespace {

// Key files are a few hundred bytes; anything far larger is not a key.
constexpr std::size_t kMaxKeyFileSize = 64 * 1024;
constexpr int kKeyBits = 1024;
constexpr int kSubgroupBits = 160;
constexpr std::string_view kSshDss = "ssh-dss";

template <typename T, void (*Free)(T*)>
struct Deleter {
  void operator()(T* p) const noexcept { Free(p); }
};
using Key = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;
using KeyContext = std::unique_ptr<EVP_PKEY_CTX, Deleter<EVP_PKEY_CTX, EVP_PKEY_CTX_free>>;
using DigestContext = std::unique_ptr<EVP_MD_CTX, Deleter<EVP_MD_CTX, EVP_MD_CTX_free>>;
using Bio = std::unique_ptr<BIO, Deleter<BIO, BIO_free_all>>;
using Number = std::unique_ptr<BIGNUM, Deleter<BIGNUM, BN_free>>;
using ParamBuilder = std::unique_ptr<OSSL_PARAM_BLD, Deleter<OSSL_PARAM_BLD, OSSL_PARAM_BLD_free>>;
using Params = std::unique_ptr<OSSL_PARAM, Deleter<OSSL_PARAM, OSSL_PARAM_free>>;

/// A failure on its way out: the code to return and, for the caller, why.
struct Error {
  int code;
  int sys_errno;
  std::string text;
};

// Every public function runs its body through this: errors become codes, the
// detail text goes to `detail`, errno is set for LNE_CHECK_ERRNO, and
// libcrypto's thread-local error queue is left empty for the program's own
// use of OpenSSL.
template <typename Body>
int run(std::string* detail, Body&& body) noexcept {
  int result = 0;
  int sys_errno = 0;
  std::string text;
  try {
    body();
  } catch (const Error& error) {
    result = -error.code;
    sys_errno = error.sys_errno;
    text = error.text;
  } catch (const std::bad_alloc&) {
    result = -LNE_NO_MEM;
    text = "out of memory";
  }
  ERR_clear_error();
  if (detail != nullptr) *detail = text;
  if (result == -LNE_CHECK_ERRNO) errno = sys_errno;
  return result;
}

[[noreturn]] void fail(int code, std::string text, int sys_errno = 0) { throw Error{code, sys_errno, std::move(text)}; }

[[noreturn]] void fail_crypto(const std::string& what) {
  char reason[256] = "no reason given";
  if (const unsigned long code = ERR_peek_last_error()) ERR_error_string_n(code, reason, sizeof reason);
  fail(LNE_INTERNAL_ERROR, what + ": " + reason);
}

[[noreturn]] void fail_key_format(const std::string& what) { fail(LNE_CHECK_ERRNO, what, EINVAL); }

std::string read_file(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int e = errno;
    fail(LNE_CHECK_ERRNO, "cannot open '" + path + "': " + std::strerror(e), e);
  }
  std::string text;
  char buffer[4096];
  for (;;) {
    const ssize_t got = ::read(fd, buffer, sizeof buffer);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      const int e = errno;
      ::close(fd);
      fail(LNE_CHECK_ERRNO, "cannot read '" + path + "': " + std::strerror(e), e);
    }
    if (got == 0) break;
    text.append(buffer, static_cast<std::size_t>(got));
    if (text.size() > kMaxKeyFileSize) {
      ::close(fd);
      fail_key_format("'" + path + "' is larger than 64 KiB: not a key file");
    }
  }
  ::close(fd);
  return text;
}

// Replaces `path` by `contents` with the given mode: a temporary file in the
// same directory, renamed over it, so a reader never sees half a key.
void write_file(const std::string& path, const std::string& contents, mode_t mode) {
  const std::string temporary = path + ".tmp" + std::to_string(::getpid());
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, mode);
  if (fd < 0) {
    const int e = errno;
    fail(LNE_CHECK_ERRNO, "cannot create '" + path + "': " + std::strerror(e), e);
  }
  auto give_up = [&](int e) {
    ::close(fd);
    ::unlink(temporary.c_str());
    fail(LNE_CHECK_ERRNO, "cannot write '" + path + "': " + std::strerror(e), e);
  };
  if (::fchmod(fd, mode) != 0) give_up(errno);  // O_CREAT's mode is reduced by the umask
  for (std::size_t done = 0; done < contents.size();) {
    const ssize_t put = ::write(fd, contents.data() + done, contents.size() - done);
    if (put < 0 && errno == EINTR) continue;
    if (put < 0) give_up(errno);
    done += static_cast<std::size_t>(put);
  }
  if (::close(fd) != 0) {
    const int e = errno;
    ::unlink(temporary.c_str());
    fail(LNE_CHECK_ERRNO, "cannot write '" + path + "': " + std::strerror(e), e);
  }
  if (::rename(temporary.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(temporary.c_str());
    fail(LNE_CHECK_ERRNO, "cannot create '" + path + "': " + std::strerror(e), e);
  }
}

// ------------------------------------------------------------------ base64

constexpr char kBase64Alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::string base64_encode(const std::string& bytes) {
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    std::uint32_t group = static_cast<std::uint8_t>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) group |= static_cast<std::uint8_t>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) group |= static_cast<std::uint8_t>(bytes[i + 2]);
    out += kBase64Alphabet[(group >> 18) & 63];
    out += kBase64Alphabet[(group >> 12) & 63];
    out += i + 1 < bytes.size() ? kBase64Alphabet[(group >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kBase64Alphabet[group & 63] : '=';
  }
  return out;
}

// Strict: only the alphabet, '=' padding at the very end, a length that is
// a multiple of 4.
bool base64_decode(std::string_view text, std::string& out) {
  if (text.size() % 4 != 0) return false;
  out.clear();
  std::uint32_t group = 0;
  int bits = 0;
  std::size_t padding = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '=') {
      if (i + 2 < text.size() || ++padding > 2) return false;
      continue;
    }
    if (padding > 0) return false;
    const char* found = std::strchr(kBase64Alphabet, c);
    if (c == '\0' || found == nullptr) return false;
    group = (group << 6) | static_cast<std::uint32_t>(found - kBase64Alphabet);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((group >> bits) & 0xff);
    }
  }
  return true;
}

// ------------------------------------------------------ OpenSSH wire format

void put_string(std::string& out, const std::string& bytes) {
  const auto n = static_cast<std::uint32_t>(bytes.size());
  const char length[4] = {static_cast<char>(n >> 24), static_cast<char>(n >> 16), static_cast<char>(n >> 8),
                          static_cast<char>(n)};
  out.append(length, 4);
  out += bytes;
}

// An SSH mpint: big-endian two's complement, minimal, with a leading zero
// byte when the top bit is set (all DSA numbers are positive).
void put_mpint(std::string& out, const BIGNUM* number) {
  std::string bytes(static_cast<std::size_t>(BN_num_bytes(number)), '\0');
  BN_bn2bin(number, reinterpret_cast<unsigned char*>(bytes.data()));
  if (!bytes.empty() && (static_cast<std::uint8_t>(bytes[0]) & 0x80)) bytes.insert(bytes.begin(), '\0');
  put_string(out, bytes);
}

class SshReader {
 public:
  explicit SshReader(std::string_view data) : data_(data) {}
  bool string(std::string_view& out) {
    if (data_.size() < 4) return false;
    const std::uint32_t n = static_cast<std::uint32_t>(static_cast<std::uint8_t>(data_[0])) << 24 |
                            static_cast<std::uint32_t>(static_cast<std::uint8_t>(data_[1])) << 16 |
                            static_cast<std::uint32_t>(static_cast<std::uint8_t>(data_[2])) << 8 |
                            static_cast<std::uint32_t>(static_cast<std::uint8_t>(data_[3]));
    if (data_.size() - 4 < n) return false;
    out = data_.substr(4, n);
    data_.remove_prefix(4 + n);
    return true;
  }
  Number mpint() {
    std::string_view bytes;
    if (!string(bytes) || bytes.empty() || (static_cast<std::uint8_t>(bytes[0]) & 0x80)) return nullptr;
    return Number(
        BN_bin2bn(reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<int>(bytes.size()), nullptr));
  }
  bool done() const { return data_.empty(); }

 private:
  std::string_view data_;
};

// "ssh-dss BASE64 [comment]" -> the key; `origin` names it in errors.
Key parse_openssh_public_key(std::string_view text, const std::string& origin) {
  auto next_word = [&text]() {
    const std::size_t start = text.find_first_not_of(" \t\r\n");
    if (start == std::string_view::npos) return std::string_view();
    text.remove_prefix(start);
    const std::size_t end = std::min(text.find_first_of(" \t\r\n"), text.size());
    const std::string_view word = text.substr(0, end);
    text.remove_prefix(end);
    return word;
  };
  const std::string_view type = next_word();
  if (type != kSshDss) fail_key_format(origin + " is not an OpenSSH DSA public key (it should start with 'ssh-dss ')");
  std::string blob;
  if (!base64_decode(next_word(), blob)) fail_key_format(origin + ": the key after 'ssh-dss ' is not valid base64");
  SshReader reader(blob);
  std::string_view inner_type;
  if (!reader.string(inner_type) || inner_type != kSshDss)
    fail_key_format(origin + ": the encoded key is not of type ssh-dss");
  Number p = reader.mpint(), q = reader.mpint(), g = reader.mpint(), y = reader.mpint();
  if (!p || !q || !g || !y || !reader.done())
    fail_key_format(origin + ": the encoded key is truncated or malformed (expected p, q, g, y)");

  ParamBuilder builder(OSSL_PARAM_BLD_new());
  if (!builder || !OSSL_PARAM_BLD_push_BN(builder.get(), OSSL_PKEY_PARAM_FFC_P, p.get()) ||
      !OSSL_PARAM_BLD_push_BN(builder.get(), OSSL_PKEY_PARAM_FFC_Q, q.get()) ||
      !OSSL_PARAM_BLD_push_BN(builder.get(), OSSL_PKEY_PARAM_FFC_G, g.get()) ||
      !OSSL_PARAM_BLD_push_BN(builder.get(), OSSL_PKEY_PARAM_PUB_KEY, y.get()))
    fail_crypto("cannot build the public key of " + origin);
  Params params(OSSL_PARAM_BLD_to_param(builder.get()));
  KeyContext context(EVP_PKEY_CTX_new_from_name(nullptr, "DSA", nullptr));
  EVP_PKEY* key = nullptr;
  if (!params || !context || EVP_PKEY_fromdata_init(context.get()) <= 0 ||
      EVP_PKEY_fromdata(context.get(), &key, EVP_PKEY_PUBLIC_KEY, params.get()) <= 0)
    fail_key_format(origin + ": libcrypto does not accept the DSA parameters in it");
  return Key(key);
}

int refuse_password(char*, int, int, void*) { return -1; }  // never prompt on a terminal

Key read_private_key(const std::string& path) {
  const std::string text = read_file(path);
  Bio bio(BIO_new_mem_buf(text.data(), static_cast<int>(text.size())));
  if (!bio) fail_crypto("cannot read '" + path + "'");
  Key key(PEM_read_bio_PrivateKey(bio.get(), nullptr, refuse_password, nullptr));
  if (!key) fail_key_format("'" + path + "' holds no PEM private key (or one protected by a password)");
  if (!EVP_PKEY_is_a(key.get(), "DSA")) fail_key_format("'" + path + "' holds a private key that is not a DSA key");
  return key;
}

int verify(const Key& key, std::string_view message, std::string_view signature, const std::string& origin) {
  DigestContext context(EVP_MD_CTX_new());
  if (!context || EVP_DigestVerifyInit(context.get(), nullptr, EVP_sha1(), nullptr, key.get()) <= 0)
    fail_crypto("cannot verify with " + origin);
  const int valid =
      EVP_DigestVerify(context.get(), reinterpret_cast<const unsigned char*>(signature.data()), signature.size(),
                       reinterpret_cast<const unsigned char*>(message.data()), message.size());
  if (valid != 1) fail(LNE_INVALID_DSA_SIGNATURE, "the signature does not verify with " + origin);
  return 0;
}

std::string bn_param(const Key& key, const char* name) {
  BIGNUM* number = nullptr;
  if (EVP_PKEY_get_bn_param(key.get(), name, &number) <= 0) fail_crypto(std::string("cannot read DSA ") + name);
  Number owned(number);
  std::string out;
  put_mpint(out, owned.get());
  return out;
}

}  // namespace

int dsa_sign(const std::string& pem_private_key_file, std::string_view message, std::string& signature,
             std::string* detail) {
  return run(detail, [&] {
    const Key key = read_private_key(pem_private_key_file);
    DigestContext context(EVP_MD_CTX_new());
    std::size_t length = 0;
    const auto* bytes = reinterpret_cast<const unsigned char*>(message.data());
    if (!context || EVP_DigestSignInit(context.get(), nullptr, EVP_sha1(), nullptr, key.get()) <= 0 ||
        EVP_DigestSign(context.get(), nullptr, &length, bytes, message.size()) <= 0)
      fail_crypto("cannot sign with '" + pem_private_key_file + "'");
    std::string out(length, '\0');
    if (EVP_DigestSign(context.get(), reinterpret_cast<unsigned char*>(out.data()), &length, bytes, message.size()) <=
        0)
      fail_crypto("cannot sign with '" + pem_private_key_file + "'");
    out.resize(length);
    signature = std::move(out);
  });
}

int dsa_verify_with_key_file(const std::string& openssh_public_key_file, std::string_view message,
                             std::string_view signature, std::string* detail) {
  return run(detail, [&] {
    const std::string origin = "'" + openssh_public_key_file + "'";
    verify(parse_openssh_public_key(read_file(openssh_public_key_file), origin), message, signature, origin);
  });
}

int dsa_verify_with_key_text(std::string_view openssh_public_key, std::string_view message, std::string_view signature,
                             std::string* detail) {
  return run(detail, [&] {
    const std::string origin = "the given public key";
    verify(parse_openssh_public_key(openssh_public_key, origin), message, signature, origin);
  });
}

int dsa_generate_key_pair(const std::string& pem_private_key_file, const std::string& openssh_public_key_file,
                          std::string* detail) {
  return run(detail, [&] {
    KeyContext parameter_context(EVP_PKEY_CTX_new_from_name(nullptr, "DSA", nullptr));
    EVP_PKEY* parameters_raw = nullptr;
    if (!parameter_context || EVP_PKEY_paramgen_init(parameter_context.get()) <= 0 ||
        EVP_PKEY_CTX_set_dsa_paramgen_bits(parameter_context.get(), kKeyBits) <= 0 ||
        EVP_PKEY_CTX_set_dsa_paramgen_q_bits(parameter_context.get(), kSubgroupBits) <= 0 ||
        EVP_PKEY_paramgen(parameter_context.get(), &parameters_raw) <= 0)
      fail_crypto("cannot generate DSA parameters");
    const Key parameters(parameters_raw);
    KeyContext key_context(EVP_PKEY_CTX_new_from_pkey(nullptr, parameters.get(), nullptr));
    EVP_PKEY* key_raw = nullptr;
    if (!key_context || EVP_PKEY_keygen_init(key_context.get()) <= 0 ||
        EVP_PKEY_keygen(key_context.get(), &key_raw) <= 0)
      fail_crypto("cannot generate a DSA key");
    const Key key(key_raw);

    Bio pem(BIO_new(BIO_s_mem()));
    if (!pem || !PEM_write_bio_PrivateKey_traditional(pem.get(), key.get(), nullptr, nullptr, 0, nullptr, nullptr))
      fail_crypto("cannot encode the private key");
    char* pem_bytes = nullptr;
    const long pem_size = BIO_get_mem_data(pem.get(), &pem_bytes);
    const std::string private_text(pem_bytes, static_cast<std::size_t>(pem_size));

    std::string blob;
    put_string(blob, std::string(kSshDss));
    blob += bn_param(key, OSSL_PKEY_PARAM_FFC_P);
    blob += bn_param(key, OSSL_PKEY_PARAM_FFC_Q);
    blob += bn_param(key, OSSL_PKEY_PARAM_FFC_G);
    blob += bn_param(key, OSSL_PKEY_PARAM_PUB_KEY);
    const std::string public_text = std::string(kSshDss) + " " + base64_encode(blob) + "\n";

    write_file(pem_private_key_file, private_text, 0600);
    write_file(openssh_public_key_file, public_text, 0644);
  });
}

}  // namespace ln::crypto
