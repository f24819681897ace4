"""Decodes every message of an MCAP file with mcap-ros2-support (an independent reader that
builds its decoders from the ros2msg schemas in the file) and prints the count per topic as JSON.
Exits 1 if any message does not decode."""
import json
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

counts = {}
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()])
    for schema, channel, message, decoded in reader.iter_decoded_messages():
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
print(json.dumps({"counts": counts}))
