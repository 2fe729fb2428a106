// pbgid's TLS server credentials from the [security] PEM files. The files
// are checked before gRPC sees them, so that a bad one is reported as what
// it is: gRPC only fails to start the server, which reads like "address in
// use".
#pragma once

#include "server/daemon/daemon_options.h"

#include <grpcpp/security/server_credentials.h>

#include <memory>
#include <string>

namespace pbgi::daemon {

// Insecure credentials without TLS. With TLS: throws IoError naming a file
// that cannot be read, InvalidArgument naming the option and file for a key
// other users may read (service/secret_files.h), a file that is not PEM, a
// certificate or key OpenSSL cannot parse, or a key that does not belong to
// the certificate.
std::shared_ptr<grpc::ServerCredentials> server_credentials(const DaemonOptions& options);

// The check of the last case on PEM text (exposed for tests): throws
// InvalidArgument naming both files unless `key_pem` is the private key of
// the first certificate in `cert_pem`.
void check_key_matches_certificate(const std::string& cert_pem, const std::string& key_pem,
                                   const std::string& cert_file, const std::string& key_file);

}  // namespace pbgi::daemon
