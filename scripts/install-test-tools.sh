#!/usr/bin/env bash
# The real client programs the tests run: mbpoll, socat, openssl (Debian) and pymodbus (PyPI)
# for the Modbus tests; bacpypes3 (PyPI) for the BACnet/IP tests; systemd's analyzers for the deployment tests; chromium (Debian) for the
# report test (tests/report.rs opens report.html in it).
# Installs only what is missing; scripts/test.sh calls it.
set -euo pipefail

missing=()
command -v mbpoll >/dev/null 2>&1 || missing+=(mbpoll)
command -v socat >/dev/null 2>&1 || missing+=(socat)
# openssl: the TLS test's certificates; systemd: systemd-analyze and systemd-sysusers for the
# deployment tests (the package installs on a system not booted by systemd too)
command -v openssl >/dev/null 2>&1 || missing+=(openssl)
command -v systemd-analyze >/dev/null 2>&1 || missing+=(systemd)
command -v chromium >/dev/null 2>&1 || missing+=(chromium)
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing ${missing[*]} (apt)"
  apt-get install -y -q "${missing[@]}" >/dev/null \
    || { apt-get update -q >/dev/null && apt-get install -y -q "${missing[@]}" >/dev/null; }
fi

PY="${LUXNODE_PYTHON:-python3}"
if ! "$PY" -c 'import pymodbus, serial' >/dev/null 2>&1; then
  echo "== installing pymodbus (pip)"
  "$PY" -m pip install -q --disable-pip-version-check 'pymodbus[serial]==3.16.1'
fi
if ! "$PY" -c 'import bacpypes3' >/dev/null 2>&1; then
  echo "== installing bacpypes3 (pip)"
  "$PY" -m pip install -q --disable-pip-version-check 'bacpypes3==0.0.110'
fi
