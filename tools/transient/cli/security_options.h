// The options of a subcommand that connects to transientd (client, view) for a daemon that
// requires TLS or authentication (docs/security.md), and to a NATS server (client, record,
// worker; docs/nats.md#security): files, never the secrets themselves.
#pragma once

#include <CLI/CLI.hpp>

#include "transient/client/client.h"
#include "transient/wire/nats.h"

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

inline void AddNatsSecurityOptions(CLI::App* command, wire::NatsConnectOptions* connect) {
  CLI::Option_group* group = command->add_option_group(
      "NATS security", "a NATS server that requires a password, credentials or TLS");
  group->add_option("--nats-user-file", connect->user_file,
                    "a file holding user:password for the NATS server (not readable by others)");
  group->add_option("--nats-creds", connect->creds_file,
                    "a NATS .creds file: a user JWT and its nkey seed (not readable by others)");
  group->add_option("--nats-ca", connect->ca_file, "PEM CA of the NATS server's certificate (TLS)");
  group->add_option("--nats-cert", connect->cert_file,
                    "PEM client certificate for the NATS server, with --nats-key");
  group->add_option("--nats-key", connect->key_file, "the PEM key of --nats-cert");
}

}  // namespace transient::tools::cli
