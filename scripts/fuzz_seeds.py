#!/usr/bin/env python3
"""Writes the seed corpora of the coverage-guided fuzz targets (fuzz-targets/seeds/TARGET/)
from the repository's real sample files, cut small so that mutations reach every part.

Run from the repository root: python3 scripts/fuzz_seeds.py [RECORDING.mcap ROS2_BAG_DIR]
The optional pair is a one-second `atrium record` MCAP file and a `--profile ros2` bag
(docs/fuzzing.md shows how to make them); without them the MCAP seeds are left as they are.
Those are rewritten uncompressed and without CRCs (needs `pip install mcap zstandard lz4 pyyaml`), so
that mutations are not all caught by a checksum."""

import bz2
import gzip
import io
import os
import sqlite3
import struct
import sys
import tempfile
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SEEDS = os.path.join(ROOT, "fuzz-targets", "seeds")


def out(target, name, data):
    d = os.path.join(SEEDS, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def pair(a, b):
    """Two files in one input (fuzz_targets/common.rs `split`)."""
    assert len(a) < 65536
    return struct.pack("<H", len(a)) + a + b


def lines(path, n, opener=open):
    with opener(path, "rt") as f:
        return "".join(f.readline() for _ in range(n))


# --- score_estimates: TUM and CSV (the MCAP ones come from the optional recordings) ---
tum = lines(os.path.join(ROOT, "datasets/fr079/fr079_reference.tum"), 12)
out("score_estimates", "fr079.tum", b"\0" + tum.encode())
rows = ["t,x,y,theta"]
for line in tum.splitlines():
    v = line.split()
    if len(v) == 8 and not line.startswith("#"):
        import math

        qx, qy, qz, qw = map(float, v[4:8])
        theta = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
        rows.append(f"{v[0]},{v[1]},{v[2]},{theta:.6f}")
out("score_estimates", "fr079.csv", b"\1" + ("\n".join(rows) + "\n").encode())

# --- carmen: the MIT log's head, plain and gzipped, and every line kind the reader knows ---
head = lines(os.path.join(ROOT, "datasets/mit-csail/mit-csail.clf.gz"), 6, gzip.open)
out("carmen", "mit_head.clf", head.encode())
out("carmen", "mit_head.clf.gz", gzip.compress(head.encode(), mtime=0))
kinds = (
    "# a comment\n"
    "PARAM robot_front_laser_max 50.0\n"
    "PARAM robot_frontlaser_offset 0.2 nohost 0\n"
    "PARAM robot_rear_laser_max 20.0\n"
    "ODOM 1.0 2.0 0.5 0.3 0.0 0.0 100.25 host 0.1\n"
    "FLASER 3 1.5 81.91 2.0 1.1 2.0 0.5 1.0 2.0 0.5 100.5 host 0.2\n"
    "RLASER 3 1.5 2.5 2.0 1.1 2.0 3.6 1.0 2.0 3.6 100.6 host 0.25\n"
    "ROBOTLASER1 0 -1.5708 3.1416 1.5708 50.0 0.01 0 3 1.0 2.0 3.0 0 1.0 2.0 0.5 1.1 2.0 0.5 "
    "0.0 0.0 0.0 0.0 0.0 100.7 host 0.4\n"
    "ODOM 1.1 2.0 0.5 0.3 0.0 0.0 100.75 host 0.3\n"
)
out("carmen", "kinds.clf", kinds.encode())


# --- ros_map: small crops of the fr079 map in every image encoding the reader takes ---
def read_pgm(path):
    data = open(path, "rb").read()
    parts = data.split(maxsplit=4)
    w, h, maxval = int(parts[1]), int(parts[2]), int(parts[3])
    return w, h, maxval, parts[4]


w, h, _, pix = read_pgm(os.path.join(ROOT, "datasets/fr079/fr079_map.pgm"))
cw, ch, x0, y0 = 24, 16, w // 2, h // 2
crop = bytes(pix[(y0 + y) * w + x0 + x] for y in range(ch) for x in range(cw))
yaml = (
    'image: "map.pgm"\nmode: trinary\nresolution: 0.05\norigin: [-25.15, -8.8, 0.0]\n'
    "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
)
p5 = b"P5\n%d %d\n255\n" % (cw, ch) + crop
out("ros_map", "p5_trinary", pair(yaml.encode(), p5))
p2 = "P2\n# an ASCII map\n%d %d\n255\n" % (cw, ch) + " ".join(map(str, crop)) + "\n"
out("ros_map", "p2_scale", pair(yaml.replace("trinary", "scale").encode(), p2.encode()))
p5_16 = b"P5\n%d %d\n65535\n" % (cw, ch) + b"".join(struct.pack(">H", v * 257) for v in crop)
out("ros_map", "p5_16bit_raw", pair(yaml.replace("trinary", "raw").replace("negate: 0", "negate: 1").encode(), p5_16))


def png(width, height, colour, depth, rows):
    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)

    raw = b"".join(b"\0" + r for r in rows)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(raw))
        + chunk(b"IEND", b"")
    )


grey = [crop[y * cw : (y + 1) * cw] for y in range(ch)]
rgba = [b"".join(bytes([v, v, v, 255]) for v in r) for r in grey]
png_yaml = yaml.replace("map.pgm", "map.png").encode()
out("ros_map", "png_grey", pair(png_yaml, png(cw, ch, 0, 8, grey)))
out("ros_map", "png_rgba", pair(png_yaml, png(cw, ch, 6, 8, rgba)))


# --- ros1: the fr079 fixture's first messages of each topic, in an uncompressed, a bz2
#     and an lz4 bag ---
OP_MSG, OP_HEADER, OP_INDEX, OP_CHUNK, OP_INFO, OP_CONN = 2, 3, 4, 5, 6, 7


def records(buf):
    i = 0
    while i + 4 <= len(buf):
        (hl,) = struct.unpack_from("<I", buf, i)
        hdr = buf[i + 4 : i + 4 + hl]
        (dl,) = struct.unpack_from("<I", buf, i + 4 + hl)
        data = buf[i + 8 + hl : i + 8 + hl + dl]
        fields = {}
        j = 0
        while j < len(hdr):
            (fl,) = struct.unpack_from("<I", hdr, j)
            name, _, value = hdr[j + 4 : j + 4 + fl].partition(b"=")
            fields[name.decode()] = value
            j += 4 + fl
        yield fields, data
        i += 8 + hl + dl


def field(name, value):
    return struct.pack("<I", len(name) + 1 + len(value)) + name.encode() + b"=" + value


def record(fields, data):
    h = b"".join(field(k, v) for k, v in fields)
    return struct.pack("<I", len(h)) + h + struct.pack("<I", len(data)) + data


def ros1_bag(conns, msgs, compression):
    """conns: {id: (header fields, data)}; msgs: [(conn id, time bytes, data)]."""
    import lz4.frame

    inner = b"".join(record(list(f.items()), d) for f, d in conns.values())
    for c, t, d in msgs:
        inner += record([("op", bytes([OP_MSG])), ("conn", struct.pack("<I", c)), ("time", t)], d)
    packed = {"none": inner, "bz2": bz2.compress(inner), "lz4": lz4.frame.compress(inner)}[compression]
    magic = b"#ROSBAG V2.0\n"
    chunk_at = len(magic) + 4096
    chunk = record(
        [("op", bytes([OP_CHUNK])), ("compression", compression.encode()), ("size", struct.pack("<I", len(inner)))],
        packed,
    )
    index_pos = chunk_at + len(chunk)
    counts = {}
    for c, _, _ in msgs:
        counts[c] = counts.get(c, 0) + 1
    times = sorted(t for _, t, _ in msgs)
    info = record(
        [
            ("op", bytes([OP_INFO])),
            ("ver", struct.pack("<I", 1)),
            ("chunk_pos", struct.pack("<Q", chunk_at)),
            ("start_time", times[0]),
            ("end_time", times[-1]),
            ("count", struct.pack("<I", len(counts))),
        ],
        b"".join(struct.pack("<II", c, n) for c, n in sorted(counts.items())),
    )
    head_fields = [
        ("op", bytes([OP_HEADER])),
        ("index_pos", struct.pack("<Q", index_pos)),
        ("conn_count", struct.pack("<I", len(conns))),
        ("chunk_count", struct.pack("<I", 1)),
    ]
    head_len = sum(len(field(k, v)) for k, v in head_fields) + 8
    head = record(head_fields, b" " * (4096 - head_len))
    tail = b"".join(record(list(f.items()), d) for f, d in conns.values())
    return magic + head + chunk + tail + info


def ros1_seeds():
    import lz4.frame

    buf = open(os.path.join(ROOT, "datasets/fixtures/fr079_head_lz4.bag"), "rb").read()
    conns, msgs, per = {}, [], {}
    for f, d in records(buf[13:]):
        if f.get("op") != bytes([OP_CHUNK]):
            continue
        inner = lz4.frame.decompress(d) if f["compression"] == b"lz4" else d
        for g, e in records(inner):
            op = g["op"][0]
            if op == OP_CONN:
                (c,) = struct.unpack("<I", g["conn"])
                conns[c] = (g, e)
            elif op == OP_MSG:
                (c,) = struct.unpack("<I", g["conn"])
                if per.get(c, 0) < 2:
                    per[c] = per.get(c, 0) + 1
                    msgs.append((c, g["time"], e))
    msgs.sort(key=lambda m: struct.unpack("<II", m[1]))
    for comp in ("none", "bz2", "lz4"):
        out("ros1", f"fr079_head_{comp}.bag", ros1_bag(conns, msgs, comp))


ros1_seeds()


# --- rosbag2: the sqlite3 fixture cut to its first messages, with its metadata ---
def rosbag2_sqlite():
    src = os.path.join(ROOT, "datasets/fixtures/fr079_head_sqlite3")
    meta = open(os.path.join(src, "metadata.yaml")).read()
    with tempfile.TemporaryDirectory() as tmp:
        db = os.path.join(tmp, "bag.db3")
        with open(os.path.join(src, "fr079_head_sqlite3.db3"), "rb") as f, open(db, "wb") as g:
            g.write(f.read())
        con = sqlite3.connect(db)
        ids = [r[0] for r in con.execute("SELECT id FROM topics")]
        for t in ids:
            con.execute(
                "DELETE FROM messages WHERE topic_id = ? AND id NOT IN "
                "(SELECT id FROM messages WHERE topic_id = ? ORDER BY timestamp LIMIT 2)",
                (t, t),
            )
        con.commit()
        counts = dict(con.execute("SELECT t.name, COUNT(*) FROM messages m JOIN topics t ON m.topic_id = t.id GROUP BY t.name"))
        stamps = [r[0] for r in con.execute("SELECT timestamp FROM messages ORDER BY timestamp")]
        con.execute("VACUUM")
        con.close()
        data = open(db, "rb").read()
    return meta, counts, stamps, data


def fix_metadata(meta, file_name, counts, stamps):
    """The metadata with the storage file renamed and the counts of what is kept."""
    import yaml

    doc = yaml.safe_load(meta)
    info = doc["rosbag2_bagfile_information"]
    info["relative_file_paths"] = [file_name]
    total = sum(counts.values())
    info["message_count"] = total
    for f in info.get("files") or []:
        f["path"] = file_name
        f["message_count"] = total
    for t in info["topics_with_message_count"]:
        t["message_count"] = counts.get(t["topic_metadata"]["name"], 0)
    return yaml.safe_dump(doc, sort_keys=False)


meta, counts, stamps, db = rosbag2_sqlite()
out("rosbag2", "fr079_head_sqlite3", pair(fix_metadata(meta, "bag.db3", counts, stamps).encode(), db))


# --- MCAP seeds from a fresh recording (optional) ---
def plain_mcap(path, keep=lambda topic: True):
    """`path` rewritten uncompressed and without CRCs, with the topics `keep` accepts."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    buf = io.BytesIO()
    w = Writer(buf, compression=CompressionType.NONE, enable_crcs=False, enable_data_crcs=False)
    with open(path, "rb") as f:
        r = make_reader(f)
        header = r.get_header()
        w.start(header.profile, header.library)
        schemas, channels, counts = {}, {}, {}
        for schema, channel, message in r.iter_messages():
            if not keep(channel.topic):
                continue
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = w.register_channel(
                    channel.topic, channel.message_encoding, schemas.get(channel.schema_id, 0), channel.metadata
                )
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            w.add_message(channels[channel.id], message.log_time, message.data, message.publish_time, message.sequence)
    w.finish()
    return buf.getvalue(), counts


if len(sys.argv) == 3:
    recording, bag = sys.argv[1], sys.argv[2]
    poses = lambda t: t in ("/ground_truth", "/odom") or t.startswith("/estimate")
    data, _ = plain_mcap(recording, poses)
    out("score_estimates", "recording.mcap", b"\0" + data)
    storage = [f for f in os.listdir(bag) if f.endswith(".mcap")][0]
    data, _ = plain_mcap(os.path.join(bag, storage), poses)
    out("score_estimates", "ros2_bag.mcap", b"\0" + data)
    # What a log scenario reads; the map, the URDF and the clock are left out (their topics
    # stay in the metadata with no messages).
    log = lambda t: poses(t) or t in ("/tf", "/tf_static", "/scan/laser")
    data, counts = plain_mcap(os.path.join(bag, storage), log)
    meta = open(os.path.join(bag, "metadata.yaml")).read()
    out("rosbag2", "recorded_mcap", pair(fix_metadata(meta, "bag.mcap", counts, []).encode(), data))
