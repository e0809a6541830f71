#!/usr/bin/env python3
"""Makes scenes/cornell_box/CornellBox.glb's lamp emit downwards only (fireflies).

Bevy's CornellBox.glb marks its emitter material doubleSided, so its lamp, a quad 0.9 mm below
the ceiling, also emits upwards into the slit between lamp and ceiling: that light reaches the
room only through the slit, which a path tracer finds by chance, and showed as white fireflies
all over the walls (383 pixels brighter than twice their 5x5 median at 256x256, 128 spp; 235 at
512 spp). The Cornell University data the model follows has a one-sided light facing down.
This sets the emitter material's doubleSided to false (the lamp's winding faces -Y, so the
light is unchanged below it) and rewrites the GLB's JSON chunk; the binary chunk is untouched.
Idempotent. Usage: scripts/make_cornell_one_sided.py [scenes/cornell_box/CornellBox.glb]
"""
import json
import struct
import sys

path = sys.argv[1] if len(sys.argv) > 1 else "scenes/cornell_box/CornellBox.glb"
data = open(path, "rb").read()
magic, version, _ = struct.unpack("<4sII", data[:12])
assert magic == b"glTF" and version == 2, "not a glTF 2.0 binary"
json_length, json_type = struct.unpack("<I4s", data[12:20])
assert json_type == b"JSON"
doc = json.loads(data[20:20 + json_length])
rest = data[20 + json_length:]
emitters = [m for m in doc["materials"] if any(m.get("emissiveFactor", [0, 0, 0]))]
assert len(emitters) == 1, "expected one emissive material"
emitters[0]["doubleSided"] = False
chunk = json.dumps(doc, separators=(",", ":")).encode()
chunk += b" " * (-len(chunk) % 4)  # the JSON chunk is padded with spaces to 4 bytes
out = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(chunk) + len(rest)) + struct.pack("<I4s", len(chunk), b"JSON") + chunk + rest
open(path, "wb").write(out)
print(f"{path}: emitter '{emitters[0].get('name')}' one-sided")
