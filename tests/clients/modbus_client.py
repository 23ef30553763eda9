#!/usr/bin/env python3
"""A BMS-side Modbus client (pymodbus), as an integrator would write it.

Reads the luxnode fixed core and every desk's lux (float32 ABCD at input 100 + 2k, u16 at
300 + k), optionally writes arc levels first (holding 1000 + j), and prints one JSON object.

    modbus_client.py --tcp 127.0.0.1:1502 [--arc 254,0,...]
    modbus_client.py --rtu /dev/pts/5 --unit 7 --baud 19200 [--arc ...]
"""

import argparse
import json
import struct
import sys

from pymodbus.client import ModbusSerialClient, ModbusTcpClient


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--tcp")
    ap.add_argument("--rtu")
    ap.add_argument("--unit", type=int, default=1)
    ap.add_argument("--baud", type=int, default=19200)
    ap.add_argument("--parity", default="E", choices=["E", "O", "N"])
    ap.add_argument("--arc", default="")
    a = ap.parse_args()
    if a.tcp:
        host, port = a.tcp.rsplit(":", 1)
        client = ModbusTcpClient(host, port=int(port), timeout=3)
    else:
        client = ModbusSerialClient(
            a.rtu, baudrate=a.baud, parity=a.parity,
            stopbits=2 if a.parity == "N" else 1, bytesize=8, timeout=1, retries=3
        )
        # pymodbus sets an inter-byte timeout (termios VTIME) that the Linux pty driver
        # rejects with EINVAL; on a pty the frame gap is the server's business anyway.
        client.inter_byte_timeout = None
    if not client.connect():
        print("cannot connect", file=sys.stderr)
        return 2
    out = {}
    try:
        if a.arc:
            levels = [int(x) for x in a.arc.split(",")]
            w = client.write_registers(1000, levels, device_id=a.unit)
            if w.isError():
                print(f"write failed: {w}", file=sys.stderr)
                return 3
        core = client.read_input_registers(0, count=4, device_id=a.unit)
        if core.isError():
            print(f"read failed: {core}", file=sys.stderr)
            return 3
        version, desks, luminaires, status = core.registers
        floats = client.read_input_registers(100, count=2 * desks, device_id=a.unit)
        ints = client.read_input_registers(300, count=desks, device_id=a.unit)
        ids = client.read_input_registers(500, count=desks, device_id=a.unit)
        arcs = client.read_holding_registers(1000, count=luminaires, device_id=a.unit)
        for r in (floats, ints, ids, arcs):
            if r.isError():
                print(f"read failed: {r}", file=sys.stderr)
                return 3
        lux = []
        regs = floats.registers
        for k in range(desks):
            raw = struct.pack(">HH", regs[2 * k], regs[2 * k + 1])
            lux.append(struct.unpack(">f", raw)[0])
        out = {
            "version": version,
            "desks": desks,
            "luminaires": luminaires,
            "status": status,
            "lux_f32": lux,
            "lux_u16": ints.registers,
            "desk_ids": ids.registers,
            "arc": arcs.registers,
        }
        # an illegal write must come back as exception 0x02
        bad = client.write_register(0, 1, device_id=a.unit)
        out["write_input_exception"] = getattr(bad, "exception_code", None)
    finally:
        client.close()
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
