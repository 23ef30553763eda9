#!/usr/bin/env python3
"""A Modbus/TCP Security client: Python's ssl (OpenSSL) with a client certificate, MBAP frames
inside TLS as the MB-TCP-Security specification has them (port 802).

Reads input registers 0..3 and the first desk's float (100, 101), optionally writes holding
register ADDR=VALUE, and prints one JSON object: the TLS version, the registers, and the write's
answer (the PDU bytes: an echo, or function | 0x80 and the exception code). A failed handshake
prints {"handshake": "failed", "error": ...} and exits 0, so the caller asserts on it.
"""
import argparse
import json
import socket
import ssl
import struct
import sys


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, required=True)
    p.add_argument("--ca", required=True, help="CA that signed the node's certificate")
    p.add_argument("--cert", help="client certificate (PEM)")
    p.add_argument("--key", help="client key (PEM)")
    p.add_argument("--write", help="ADDR=VALUE, a holding register to write")
    a = p.parse_args()

    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    ctx.minimum_version = ssl.TLSVersion.TLSv1_2
    ctx.load_verify_locations(a.ca)
    if a.cert:
        ctx.load_cert_chain(a.cert, a.key)
    out = {}
    try:
        raw = socket.create_connection((a.host, a.port), timeout=5)
        s = ctx.wrap_socket(raw, server_hostname="localhost")
        out["version"] = s.version()
        tid = [0]

        def recvn(n):
            b = b""
            while len(b) < n:
                c = s.recv(n - len(b))
                if not c:
                    raise ConnectionError("closed")
                b += c
            return b

        def ask(pdu):
            tid[0] += 1
            s.sendall(struct.pack(">HHHB", tid[0], 0, len(pdu) + 1, 1) + pdu)
            h = recvn(7)
            assert struct.unpack(">H", h[:2])[0] == tid[0]
            return recvn(struct.unpack(">H", h[4:6])[0] - 1)

        r = ask(struct.pack(">BHH", 4, 0, 4))
        out["core"] = list(struct.unpack(">4H", r[2:10]))
        r = ask(struct.pack(">BHH", 4, 100, 2))
        out["desk0_lux"] = struct.unpack(">f", r[2:6])[0]
        if a.write:
            addr, value = (int(x) for x in a.write.split("="))
            out["write"] = list(ask(struct.pack(">BHH", 6, addr, value)))
        s.close()
    except (ssl.SSLError, ConnectionError, OSError) as e:
        if "version" not in out or "core" not in out:
            print(json.dumps({"handshake": "failed", "error": str(e)}))
            return 0
        raise
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
