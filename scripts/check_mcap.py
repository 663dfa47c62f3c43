"""Reads an Atrium recording with the official MCAP Python tools, the way a user's pipeline
would: CRCs validated, every protobuf message decoded with its embedded schema, every JSON
message parsed. Camera images (`/image/<camera>`, `/disparity/<rig>`, foxglove.RawImage) are
checked further: the encoding (`mono8` for intensity, `32FC1` for disparity), width × height ×
bytes per pixel = len(data) with step = width × bytes per pixel, and the intrinsics in the
channel metadata. Exits non-zero, naming the topic, on the first thing that fails.

Usage: python check_mcap.py FILE.mcap [TOPIC=MIN_COUNT ...]
"""

import json
import math
import struct
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


# Image topics: prefix -> (encoding, bytes per pixel, channel metadata keys).
IMAGE_TOPICS = {
    "/image/": ("mono8", 1, ("fx", "fy", "cx", "cy", "projection", "mount_xyz", "mount_rpy")),
    "/disparity/": ("32FC1", 4, ("fx", "baseline")),
}


def check_image(topic, channel, msg):
    """None if the RawImage on `topic` is well formed, else what is wrong."""
    for prefix, (encoding, bpp, keys) in IMAGE_TOPICS.items():
        if not topic.startswith(prefix):
            continue
        if msg.encoding != encoding:
            return f"encoding {msg.encoding!r}, expected {encoding!r}"
        if msg.width == 0 or msg.height == 0:
            return f"empty image {msg.width}x{msg.height}"
        if msg.step != msg.width * bpp:
            return f"step {msg.step}, expected width x {bpp} = {msg.width * bpp}"
        if msg.width * msg.height * bpp != len(msg.data):
            return f"{msg.width}x{msg.height}x{bpp} = {msg.width * msg.height * bpp} bytes expected, data has {len(msg.data)}"
        for k in keys:
            if k not in channel.metadata:
                return f"channel metadata lacks {k!r}"
        for k in ("fx", "fy", "baseline"):
            if k in keys and not float(channel.metadata[k]) > 0:
                return f"metadata {k} = {channel.metadata[k]!r} is not > 0"
        if encoding == "32FC1":
            # Little-endian floats: NaN marks a missing disparity, the rest are >= 0.
            values = struct.unpack(f"<{msg.width * msg.height}f", bytes(msg.data))
            if any(v < 0 or math.isinf(v) for v in values if not math.isnan(v)):
                return "a disparity is negative or infinite"
        if "projection" in keys:
            projection = channel.metadata["projection"]
            if projection not in ("pinhole", "cylindrical"):
                return f"unknown projection {projection!r}"
            if projection == "cylindrical":
                fx = float(channel.metadata["fx"])
                if abs(fx * 2 * math.pi - msg.width) > 1e-6 * msg.width:
                    return f"a panorama's fx must be width / 2pi, got {fx} for {msg.width} columns"
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
            if schema is not None and schema.name == "foxglove.RawImage":
                problem = check_image(channel.topic, channel, decoded)
                if problem is not None:
                    print(f"{path}: {channel.topic}: {problem}", file=sys.stderr)
                    return 1
            elif channel.topic.startswith(tuple(IMAGE_TOPICS)):
                print(f"{path}: {channel.topic}: schema {schema.name if schema else None!r}, expected foxglove.RawImage", file=sys.stderr)
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
