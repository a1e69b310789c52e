#!/usr/bin/env bash
# Licences, bans and sources (cargo-deny): the whole workspace against deny.toml, then each
# shipped binary's own graph against its stricter list (host-tool: no GPL at all, so no
# emulator; the board binary: permissive licences only). Advisories need the advisory database
# from the network, which CI does not reach; they are not checked here.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo-deny >/dev/null; then
  cargo install --locked cargo-deny@0.20.2 >/dev/null
fi
cargo deny --version

# `cargo metadata` (what cargo-deny reads) needs every package of the lock file, other
# platforms' too, which the builds never download: fetched first (from crates.io, as the builds).
cargo fetch --locked
deny() { cargo deny --locked --offline "$@"; }

echo "workspace:"
deny --config deny.toml check licenses bans sources
echo "host-tool's own graph (no GPL exception):"
deny --manifest-path crates/host-tool/Cargo.toml --exclude-dev --config .ci/deny-host-tool.toml \
  check licenses
echo "the board binary's own graph (permissive only):"
deny --manifest-path crates/firmware/Cargo.toml --exclude-dev --target thumbv7em-none-eabihf \
  --features board-uno-r4 --config .ci/deny-firmware.toml check licenses
