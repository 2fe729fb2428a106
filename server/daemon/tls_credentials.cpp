#include "server/daemon/tls_credentials.h"

#include "common/errors.h"
#include "server/service/secret_files.h"

#include <fmt/format.h>
#include <grpcpp/security/server_credentials.h>
#include <openssl/bio.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

namespace pbgi::daemon {
namespace {

std::string read_pem(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(fmt::format("cannot read {} '{}': {}", what, path, std::strerror(errno)));
  std::ostringstream text;
  text << in.rdbuf();
  if (text.str().find("-----BEGIN") == std::string::npos) {
    throw InvalidArgument(fmt::format("{} '{}' is not a PEM file", what, path));
  }
  return text.str();
}

struct BioFree {
  void operator()(BIO* b) const { BIO_free(b); }
};
struct X509Free {
  void operator()(X509* x) const { X509_free(x); }
};
struct KeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};

std::unique_ptr<BIO, BioFree> memory_bio(const std::string& text) {
  return std::unique_ptr<BIO, BioFree>(BIO_new_mem_buf(text.data(), static_cast<int>(text.size())));
}

}  // namespace

void check_key_matches_certificate(const std::string& cert_pem, const std::string& key_pem,
                                   const std::string& cert_file, const std::string& key_file) {
  const std::unique_ptr<X509, X509Free> cert(PEM_read_bio_X509(memory_bio(cert_pem).get(), nullptr, nullptr, nullptr));
  if (!cert) throw InvalidArgument(fmt::format("security.tls_cert '{}' holds no PEM certificate", cert_file));
  const std::unique_ptr<EVP_PKEY, KeyFree> key(
      PEM_read_bio_PrivateKey(memory_bio(key_pem).get(), nullptr, nullptr, nullptr));
  if (!key) {
    throw InvalidArgument(
        fmt::format("security.tls_key '{}' holds no unencrypted PEM private key", key_file));
  }
  if (X509_check_private_key(cert.get(), key.get()) != 1) {
    throw InvalidArgument(fmt::format("security.tls_key '{}' does not match the certificate in security.tls_cert '{}'",
                                      key_file, cert_file));
  }
}

std::shared_ptr<grpc::ServerCredentials> server_credentials(const DaemonOptions& options) {
  if (!options.tls()) return grpc::InsecureServerCredentials();
  service::check_secret_file_mode(options.tls_key, "security.tls_key");
  grpc::SslServerCredentialsOptions ssl;
  const std::string key = read_pem(options.tls_key, "security.tls_key");
  const std::string cert = read_pem(options.tls_cert, "security.tls_cert");
  check_key_matches_certificate(cert, key, options.tls_cert, options.tls_key);
  ssl.pem_key_cert_pairs.push_back({key, cert});
  if (!options.tls_client_ca.empty()) {
    ssl.pem_root_certs = read_pem(options.tls_client_ca, "security.tls_client_ca");
    ssl.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  } else {
    ssl.client_certificate_request = GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE;
  }
  return grpc::SslServerCredentials(ssl);
}

}  // namespace pbgi::daemon
