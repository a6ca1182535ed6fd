// The options of a subcommand that connects to transientd (client, view) for a daemon that
// requires TLS or authentication (docs/security.md): files, never the secrets themselves.
#pragma once

#include <CLI/CLI.hpp>

#include "transient/client/client.h"

namespace transient::tools::cli {

inline void AddSecurityOptions(CLI::App* command, client::ChannelSecurity* security) {
  CLI::Option_group* group = command->add_option_group(
      "Security", "a daemon that requires TLS, a client certificate or a token");
  group->add_option("--ca", security->ca_file,
                    "connect with TLS, trusting this PEM CA for the daemon's certificate");
  group->add_option("--cert", security->cert_file,
                    "PEM client certificate for a daemon with --client-ca (needs --key, --ca)");
  group->add_option("--key", security->key_file, "the PEM private key of --cert");
  group->add_option("--server-name", security->server_name,
                    "the name the daemon's certificate carries, when not the --connect host");
  group->add_option("--token-file", security->token_file,
                    "send the bearer token in this file with every call (the daemon's "
                    "--token-file)");
}

}  // namespace transient::tools::cli
