"""Decodes CDR messages with their .msg definitions through mcap-ros2-support, an independent
decoder, and prints them as JSON. Input (stdin): a JSON list of
{"schema_name": "pkg/msg/Type", "schema_text": "...", "cdr_hex": "..."}."""
import json
import sys

from mcap_ros2._dynamic import generate_dynamic


def plain(v):
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, (bytes, bytearray)):
        return list(v)
    if hasattr(v, "__slots__"):
        return {k: plain(getattr(v, k)) for k in v.__slots__}
    return v


out = []
for item in json.load(sys.stdin):
    decoders = generate_dynamic(item["schema_name"], item["schema_text"])
    msg = decoders[item["schema_name"]](bytes.fromhex(item["cdr_hex"]))
    out.append(plain(msg))
print(json.dumps(out))
