#!/usr/bin/env python3
"""Seeds of the fuzz corpora (fuzz/corpus/<target>/), committed. Method: one or a few valid
inputs per decoder, as small as they can be while reaching the decoder's whole structure:

* modbus_pdu / modbus_rtu: a request of every supported function (RTU frames with their
  CRC-16/MODBUS), written here from the specification;
* eulumdat, ies: the smallest files of reference/photometry (copied);
* obj_mtl: a unit quad and its material (OBJ, NUL byte, MTL), written here;
* scene_json: office_a's luminaires.json, sensors.json, desks.json, camera.json, each after its
  selector byte (0..3);
* capture_png: 4 x 4 16-bit greyscale PNGs (a ramp and zeros), encoded here with zlib;
* board_toml: the repository's board files;
* flash_image: the payload of a tiny image (office_a, 3 m patches, few rays, u8; `--detail 0 --light-detail 0`) built by
  `luxnode image build`, after the generation and precision bytes the target reads first.

Run from the repository: python3 fuzz/make-corpus.py (after cargo build --release).
"""
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(ROOT, "..", "shared")
OUT = os.path.join(ROOT, "fuzz", "corpus")


def put(target, name, data):
    d = os.path.join(OUT, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def crc16(b):
    c = 0xFFFF
    for x in b:
        c ^= x
        for _ in range(8):
            c = (c >> 1) ^ 0xA001 if c & 1 else c >> 1
    return c


def png16(w, h, values):
    raw = b"".join(b"\x00" + b"".join(struct.pack(">H", v) for v in values[r * w:(r + 1) * w]) for r in range(h))

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def main():
    if os.path.isdir(OUT):
        shutil.rmtree(OUT)
    pdus = {
        "read_input": bytes([4, 0, 100, 0, 16]),
        "read_holding": bytes([3, 3, 0xE8, 0, 8]),
        "write_single": bytes([6, 3, 0xE8, 0, 254]),
        "write_multiple": bytes([0x10, 3, 0xE8, 0, 2, 4, 0, 229, 0, 255]),
        "word_order": bytes([6, 7, 0xD0, 0, 3]),
        "device_id": bytes([0x2B, 0x0E, 1, 0]),
        "health": bytes([4, 0, 40, 0, 12]),
    }
    for name, p in pdus.items():
        put("modbus_pdu", name, p)
        for unit in (7, 0):
            f = bytes([unit]) + p
            put("modbus_rtu", f"{name}_unit{unit}", f + struct.pack("<H", crc16(f)))
    photo = os.path.join(SHARED, "photometry")
    put("eulumdat", "asym.ldt", open(os.path.join(photo, "ldt-manufacturer",
        "4058075580657_FL_MAX_LUM_900W_757_ASYM_50X110_WAL.ldt"), "rb").read())
    put("ies", "tilt.ies", open(os.path.join(photo, "ies-edge", "TILT_TEST_SYNTHETIC.ies"), "rb").read())
    put("ies", "lab7.ies", open(os.path.join(photo, "ies-lab", "7.ies"), "rb").read())
    obj = b"mtllib scene.mtl\nusemtl grey\ng floor\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
    mtl = b"newmtl grey\nKd 0.5 0.5 0.5\n"
    put("obj_mtl", "quad", obj + b"\x00" + mtl)
    office = os.path.join(SHARED, "scenes", "office_a")
    for k, name in enumerate(["luminaires.json", "sensors.json", "desks.json", "camera.json"]):
        put("scene_json", name, bytes([k]) + open(os.path.join(office, name), "rb").read())
    put("capture_png", "ramp", png16(4, 4, [2000 + 10 * i for i in range(16)]))
    put("capture_png", "zeros", png16(4, 4, [0] * 16))
    for b in sorted(os.listdir(os.path.join(ROOT, "boards"))):
        f = os.path.join(ROOT, "boards", b, "board.toml")
        if os.path.isfile(f):
            put("board_toml", b, open(f, "rb").read())
    luxnode = os.path.join(ROOT, "target", "release", "luxnode")
    with tempfile.TemporaryDirectory() as t:
        img = os.path.join(t, "tiny.img")
        subprocess.run([luxnode, "image", "build", "--scene", office, "--out", img,
                        "--patch-size", "3", "--min-patch", "3", "--detail", "0",
                        "--light-detail", "0", "--rays", "50", "--sensor-rays", "100",
                        "--final-gather-rays", "0", "--precision", "u8"],
                       check=True, stdout=subprocess.DEVNULL)
        b = open(img, "rb").read()
        put("flash_image", "tiny", bytes([1, b[24]]) + b[40:])
    return 0


if __name__ == "__main__":
    sys.exit(main())
