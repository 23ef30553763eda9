#!/usr/bin/env python3
"""A BMS-side BACnet/IP client (bacpypes3), as an integrator would drive one.

Each command prints one JSON object on stdout:

    bacnet_client.py --local 127.0.0.1:47900 --target 127.0.0.1:47808 whois [--low N --high N]
    ... whohas (--id OBJ | --name NAME) [--low N --high N]
                               Who-Has; every I-Have heard in 2 s (device, object, name)
    ... read                   every object of the device: RPM ALL per object, RP Present_Value
    ... rp OBJ PROP            ReadProperty of one property (e.g. device,4321 reliability)
    ... write OBJ PROP VALUE   WriteProperty (e.g. analog-value,1000 present-value 420)
    ... cov OBJ (--write OBJ2 VALUE | --write-modbus HOST:PORT REGISTER VALUE)
            [--confirmed] [--subscribers N]
                               SubscribeCOV (N subscriptions, process ids 1..N), then the write
                               (BACnet, or Modbus with pymodbus), then the time until each
                               subscriber saw a notification
    ... hold OBJ [--subscribers N --seconds S]
                               N subscriptions held S seconds; notifications counted per one
    ... raw HEX                one datagram as is; the first answer's bytes (hex) or none

--local is the client's own address (another loopback address, e.g. 127.0.0.2, is another
source for the node's write allowlist).
"""

import argparse
import asyncio
import json
import math
import socket
import sys
import time

from bacpypes3.apdu import ErrorRejectAbortNack
from bacpypes3.app import Application
from bacpypes3.argparse import SimpleArgumentParser
from bacpypes3.pdu import Address
from bacpypes3.primitivedata import ObjectIdentifier, Real


def plain(v):
    """A bacpypes3 value as JSON."""
    if isinstance(v, float):
        return None if math.isnan(v) else v
    if isinstance(v, (int, str, bool)) or v is None:
        return v
    if isinstance(v, ObjectIdentifier):
        return [str(v[0]), v[1]]
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    # enumerations, bit strings, character strings
    return str(v)


def error_text(e):
    return f"{type(e).__name__}: {e}"


async def make_app(local: str) -> Application:
    host, port = local.rsplit(":", 1)
    args = SimpleArgumentParser().parse_args(
        ["--name", "bms", "--instance", "999001", "--address", f"{host}/8:{port}"]
    )
    return Application.from_args(args)


async def cmd_whois(app, target, a):
    i_ams = await app.who_is(a.low, a.high, Address(target), timeout=2)
    return {
        "i_am": [
            {
                "device": plain(i.iAmDeviceIdentifier),
                "max_apdu": i.maxAPDULengthAccepted,
                "segmentation": str(i.segmentationSupported),
                "vendor": i.vendorID,
            }
            for i in i_ams
        ]
    }


async def cmd_whohas(app, target, a):
    i_haves = await app.who_has(
        a.low,
        a.high,
        ObjectIdentifier(a.id) if a.id else None,
        a.name,
        Address(target),
        timeout=2,
    )
    return {
        "i_have": [
            {
                "device": plain(i.deviceIdentifier),
                "object": plain(i.objectIdentifier),
                "name": str(i.objectName),
            }
            for i in i_haves
        ]
    }


async def cmd_read(app, target, a):
    addr = Address(target)
    device = ObjectIdentifier(f"device,{a.device}")
    count = await app.read_property(addr, device, "object-list", 0)
    objects = [
        await app.read_property(addr, device, "object-list", k) for k in range(1, count + 1)
    ]
    out = {"object_count": count, "objects": {}}
    dev_props = await app.read_property_multiple(addr, [device, ["all"]])
    out["device"] = {str(p): plain(v) for (_, p, _, v) in dev_props}
    for obj in objects:
        if str(obj[0]) == "device":
            continue
        rows = await app.read_property_multiple(addr, [obj, ["all"]])
        props = {str(p): plain(v) for (_, p, _, v) in rows}
        rp = await app.read_property(addr, obj, "present-value")
        props["rp-present-value"] = plain(float(rp))
        out["objects"][f"{obj[0]},{obj[1]}"] = props
    return out


async def cmd_rp(app, target, a):
    try:
        v = await app.read_property(Address(target), ObjectIdentifier(a.object), a.prop)
    except ErrorRejectAbortNack as e:
        return {"ok": False, "error": error_text(e)}
    return {"ok": True, "value": plain(v)}


async def cmd_write(app, target, a):
    try:
        v = await app.write_property(
            Address(target),
            ObjectIdentifier(a.object),
            a.prop,
            Real(float(a.value)),
            priority=a.priority,
        )
    except ErrorRejectAbortNack as e:
        return {"ok": False, "error": error_text(e)}
    if isinstance(v, ErrorRejectAbortNack):
        return {"ok": False, "error": error_text(v)}
    return {"ok": True}


async def cmd_cov(app, target, a):
    addr = Address(target)
    obj = ObjectIdentifier(a.object)
    contexts = []
    initial = []
    for pid in range(1, a.subscribers + 1):
        scm = app.change_of_value(addr, obj, pid, a.confirmed, 120)
        await scm.__aenter__()
        contexts.append(scm)
    for scm in contexts:
        initial.append(await asyncio.wait_for(drain_value(scm), 3))
    if a.write_modbus:
        from pymodbus.client import ModbusTcpClient

        host, port = a.write_modbus[0].rsplit(":", 1)
        mb = ModbusTcpClient(host, port=int(port), timeout=3)
        if not mb.connect():
            return {"ok": False, "error": "modbus: cannot connect"}
        r = mb.write_register(int(a.write_modbus[1]), int(a.write_modbus[2]), device_id=1)
        t0 = time.monotonic()
        mb.close()
        if r.isError():
            return {"ok": False, "error": f"modbus write: {r}"}
    else:
        w = await app.write_property(
            addr, ObjectIdentifier(a.write[0]), "present-value", Real(float(a.write[1]))
        )
        t0 = time.monotonic()
        if isinstance(w, ErrorRejectAbortNack):
            return {"ok": False, "error": error_text(w)}
    after, elapsed = [], []
    for scm in contexts:
        try:
            v = await asyncio.wait_for(drain_value(scm), max(0.05, 3 - (time.monotonic() - t0)))
            after.append(v)
            elapsed.append(time.monotonic() - t0)
        except asyncio.TimeoutError:
            after.append(None)
            elapsed.append(None)
    for scm in contexts:
        await scm.__aexit__(None, None, None)
    return {"ok": True, "initial": initial, "after": after, "elapsed_s": elapsed}


async def cmd_hold(app, target, a):
    """Holds N subscriptions for S seconds; counts the notifications each received."""
    addr = Address(target)
    obj = ObjectIdentifier(a.object)
    contexts = []
    for pid in range(1, a.subscribers + 1):
        scm = app.change_of_value(addr, obj, pid, False, 300)
        await scm.__aenter__()
        contexts.append(scm)
    counts = [0] * len(contexts)

    async def count(k, scm):
        while True:
            await drain_value(scm)
            counts[k] += 1

    tasks = [asyncio.create_task(count(k, s)) for k, s in enumerate(contexts)]
    await asyncio.sleep(a.seconds)
    for t in tasks:
        t.cancel()
    for scm in contexts:
        await scm.__aexit__(None, None, None)
    return {"notifications": counts}


async def drain_value(scm):
    """The next Present_Value notified (Status_Flags and others skipped)."""
    while True:
        prop, value = await scm.get_value()
        if str(prop) == "present-value":
            return plain(float(value))


def cmd_raw(local, target, hexstr):
    host, port = local.rsplit(":", 1)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind((host, int(port)))
    s.settimeout(1.0)
    th, tp = target.rsplit(":", 1)
    s.sendto(bytes.fromhex(hexstr), (th, int(tp)))
    try:
        data, _ = s.recvfrom(2048)
        return {"answer": data.hex()}
    except socket.timeout:
        return {"answer": None}


async def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--local", required=True)
    ap.add_argument("--target", required=True)
    ap.add_argument("--device", type=int, default=1)
    sub = ap.add_subparsers(dest="cmd", required=True)
    w = sub.add_parser("whois")
    w.add_argument("--low", type=int)
    w.add_argument("--high", type=int)
    wh = sub.add_parser("whohas")
    wh.add_argument("--id")
    wh.add_argument("--name")
    wh.add_argument("--low", type=int)
    wh.add_argument("--high", type=int)
    sub.add_parser("read")
    rp = sub.add_parser("rp")
    rp.add_argument("object")
    rp.add_argument("prop")
    wr = sub.add_parser("write")
    wr.add_argument("object")
    wr.add_argument("prop")
    wr.add_argument("value")
    wr.add_argument("--priority", type=int)
    c = sub.add_parser("cov")
    c.add_argument("object")
    c.add_argument("--write", nargs=2, metavar=("OBJECT", "VALUE"))
    c.add_argument("--write-modbus", nargs=3, metavar=("ADDR", "REGISTER", "VALUE"))
    c.add_argument("--confirmed", action="store_true")
    c.add_argument("--subscribers", type=int, default=1)
    h = sub.add_parser("hold")
    h.add_argument("object")
    h.add_argument("--subscribers", type=int, default=100)
    h.add_argument("--seconds", type=float, default=10)
    r = sub.add_parser("raw")
    r.add_argument("hex")
    a = ap.parse_args()
    if a.cmd == "raw":
        print(json.dumps(cmd_raw(a.local, a.target, a.hex)))
        return 0
    app = await make_app(a.local)
    try:
        f = {"whois": cmd_whois, "whohas": cmd_whohas, "rp": cmd_rp, "read": cmd_read, "write": cmd_write, "cov": cmd_cov, "hold": cmd_hold}[a.cmd]
        out = await f(app, a.target, a)
    finally:
        app.close()
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(asyncio.run(main()))
