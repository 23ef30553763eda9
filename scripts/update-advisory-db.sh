#!/usr/bin/env bash
# Refreshes deny/advisory-db.tar.gz, the snapshot of the RustSec advisory database (CC0) that
# scripts/deny.sh checks the dependency graph against without network.
# Usage: scripts/update-advisory-db.sh PATH_TO_A_CLONE_OF_rustsec/advisory-db
# Then update the commit and date named in scripts/deny.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
src="${1:?path to a clone of https://github.com/rustsec/advisory-db}"
git -C "$src" log -1 --format='snapshot of rustsec/advisory-db %H (%cs)'
git -C "$src" archive --prefix=advisory-db/ HEAD crates LICENSE.txt | gzip -9n > deny/advisory-db.tar.gz
ls -l deny/advisory-db.tar.gz
