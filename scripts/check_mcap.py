"""Reads an Atrium recording with the official MCAP Python tools, the way a user's pipeline
would: CRCs validated, every protobuf message decoded with its embedded schema, every JSON
message parsed. Exits non-zero, naming the topic, on the first thing that fails.

Usage: python check_mcap.py FILE.mcap [TOPIC=MIN_COUNT ...]
"""

import json
import sys
from collections import Counter

from mcap.decoder import DecoderFactory as McapDecoderFactory
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


class JsonDecoderFactory(McapDecoderFactory):
    """JSON-encoded channels (WiFi scans, landmark detections, odometry ticks, scores)."""

    def decoder_for(self, message_encoding, schema):
        if message_encoding == "json":
            return lambda data: json.loads(data)
        return None


def main() -> int:
    path = sys.argv[1]
    minimum = {}
    for arg in sys.argv[2:]:
        topic, count = arg.rsplit("=", 1)
        minimum[topic] = int(count)
    counts = Counter()
    schemas = {}
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory(), JsonDecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            counts[channel.topic] += 1
            schemas[channel.topic] = schema.name if schema else ""
            if decoded is None:
                print(f"{path}: {channel.topic}: could not decode", file=sys.stderr)
                return 1
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    if "atrium" not in metadata or "seed" not in metadata["atrium"]:
        print(f"{path}: metadata 'atrium' with the seed is missing", file=sys.stderr)
        return 1
    for topic, need in minimum.items():
        if counts[topic] < need:
            print(f"{path}: {topic}: {counts[topic]} messages, expected at least {need}", file=sys.stderr)
            return 1
    for topic in sorted(counts):
        print(f"{topic:28} {schemas[topic]:28} {counts[topic]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
