"""Reads an Atrium ROS 2 recording (`atrium record --profile ros2`) with an independent reader,
the Python `rosbags` package, the way a ROS user's pipeline would, and compares it with the
Foxglove-profile recording of the same run.

Checks, each failure naming the topic:
- the bag opens (metadata.yaml, MCAP storage) and every message of every topic deserializes
  with the ROS 2 Humble type store (`atrium_msgs/msg/*` registered from the bag's own
  `ros2msg` schemas), and serializes back to exactly the recorded bytes (so the encoder's
  alignment and padding are what ROS 2 produces);
- every standard type's schema in the bag defines the same fields as the Humble type store;
- message counts equal metadata.yaml's; TOPIC=MIN_COUNT minimums;
- REP 105 frames: /odom in `odom` with the base link as child, /tf carrying odom -> base only
  (map -> odom too with --tf-ground-truth, the bag recorded with that flag), every sensor
  frame (scan, image headers) in /tf_static, each child frame with one parent there, ground
  truth (nav_msgs/Odometry, child the base link) and estimates in `map`; /map, /tf_static and
  /robot_description offered transient local;
- with --doc docs/ros2.md: every row of the walk-through's table (topic, type, frame, child
  frame, durability) and its promises: /odom twist and covariances, +Inf no-return beams with
  scan_time and time_increment, unknown cells in /map, the wheel joints on /joint_states;
- with --foxglove FILE.mcap (read with `mcap` + `mcap-protobuf-support`): per topic the same
  number of messages at the same times, and equal field values: laser ranges (float32 of the
  Foxglove float64, and the exact float64 side channel bit for bit), odometry, ground-truth
  and estimate poses, depth/intensity/disparity pixels, WiFi scans, landmark detections,
  wheel ticks, scoring instants and /tf transforms.

Usage: python check_rosbag.py BAG_DIR [--foxglove FILE.mcap] [--doc docs/ros2.md]
       [--tf-ground-truth] [TOPIC=MIN_COUNT ...]
"""

import json
import math
import struct
import sys
from collections import Counter, defaultdict
from pathlib import Path

from rosbags.interfaces import QosDurability
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

TRANSIENT_LOCAL = ("/map", "/tf_static", "/robot_description")


class Failed(Exception):
    pass


def fail(topic, what):
    raise Failed(f"{topic}: {what}")


def stamp_ns(header):
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def read_bag(path):
    """topic -> list of (log time ns, message); topic -> type; the type store."""
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    messages = defaultdict(list)
    types = {}
    with Reader(path) as reader:
        # Atrium's own types from the bag's schemas; the standard ones must match Humble's.
        custom = {}
        for conn in reader.connections:
            types[conn.topic] = conn.msgtype
            if not conn.msgdef.data:
                fail(conn.topic, "the storage file has no message definition for it")
            defs = get_types_from_msg(conn.msgdef.data, conn.msgtype)
            for name, fields in defs.items():
                if name.startswith("atrium_msgs/"):
                    custom[name] = fields
                elif name not in typestore.fielddefs:
                    fail(conn.topic, f"type {name} is neither standard nor atrium_msgs")
                elif typestore.fielddefs[name][1] != fields[1]:
                    fail(conn.topic, f"schema of {name} differs from ROS 2 Humble's: {fields[1]} vs {typestore.fielddefs[name][1]}")
            qos = conn.ext.offered_qos_profiles
            transient = bool(qos) and all(q.durability == QosDurability.TRANSIENT_LOCAL for q in qos)
            if transient != (conn.topic in TRANSIENT_LOCAL):
                fail(conn.topic, f"offered QoS durability {[q.durability for q in qos]}")
        typestore.register(custom)
        counts = Counter()
        for conn, timestamp, raw in reader.messages():
            msg = typestore.deserialize_cdr(raw, conn.msgtype)
            again = typestore.serialize_cdr(msg, conn.msgtype)
            if bytes(again) != bytes(raw):
                fail(conn.topic, f"message at {timestamp} ns does not serialize back to the recorded bytes ({len(again)} vs {len(raw)})")
            header = getattr(msg, "header", None)
            if header is not None and stamp_ns(header) != timestamp:
                fail(conn.topic, f"header stamp {stamp_ns(header)} ns differs from the log time {timestamp} ns")
            messages[conn.topic].append((timestamp, msg))
            counts[conn.topic] += 1
        for conn in reader.connections:
            if counts[conn.topic] != conn.msgcount:
                fail(conn.topic, f"{counts[conn.topic]} messages, metadata.yaml says {conn.msgcount}")
    return messages, types


def check_frames(messages, types, tf_ground_truth=False):
    base = None
    for _, m in messages.get("/odom", []):
        if m.header.frame_id != "odom":
            fail("/odom", f"frame {m.header.frame_id!r}, expected 'odom'")
        base = m.child_frame_id
    if base is None:
        fail("/odom", "no messages")
    pairs = {(t.header.frame_id, t.child_frame_id) for _, m in messages.get("/tf", []) for t in m.transforms}
    if ("odom", base) not in pairs:
        fail("/tf", f"no transform odom -> {base} (has {sorted(pairs)})")
    if (("map", "odom") in pairs) != tf_ground_truth:
        fail("/tf", f"map -> odom {'missing' if tf_ground_truth else 'present: the localizer under test publishes it'} (has {sorted(pairs)})")
    if tf_ground_truth and pairs != {("odom", base), ("map", "odom")}:
        fail("/tf", f"transforms other than odom -> base and map -> odom: {sorted(pairs)}")
    if not tf_ground_truth and pairs != {("odom", base)}:
        fail("/tf", f"transforms other than odom -> {base}: {sorted(pairs)}")
    parent_of = {}
    for _, m in messages.get("/tf_static", []):
        for t in m.transforms:
            if parent_of.setdefault(t.child_frame_id, t.header.frame_id) != t.header.frame_id:
                fail("/tf_static", f"frame {t.child_frame_id!r} has two parents: {parent_of[t.child_frame_id]!r} and {t.header.frame_id!r}")
    static = {t.child_frame_id for _, m in messages.get("/tf_static", []) for t in m.transforms}
    parents = {t.header.frame_id for _, m in messages.get("/tf_static", []) for t in m.transforms}
    if not static:
        fail("/tf_static", "no transforms")
    for topic, msgtype in types.items():
        if msgtype in ("sensor_msgs/msg/LaserScan", "sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo"):
            for _, m in messages[topic]:
                if m.header.frame_id not in static:
                    fail(topic, f"frame {m.header.frame_id!r} is not in /tf_static ({sorted(static)})")
        if topic == "/ground_truth" or topic.startswith("/estimate/"):
            for _, m in messages[topic]:
                if m.header.frame_id != "map":
                    fail(topic, f"frame {m.header.frame_id!r}, expected 'map'")
        if topic == "/ground_truth":
            if msgtype != "nav_msgs/msg/Odometry":
                fail(topic, f"type {msgtype}, expected nav_msgs/msg/Odometry")
            for _, m in messages[topic]:
                if m.child_frame_id != base:
                    fail(topic, f"child frame {m.child_frame_id!r}, expected {base!r}")
    if base not in parents:
        fail("/tf_static", f"no transform from the base link {base!r}")
    urdf = messages.get("/robot_description", [(0, None)])[0][1]
    if urdf is None or "<robot" not in urdf.data:
        fail("/robot_description", "no URDF")
    grid = messages.get("/map", [(0, None)])[0][1]
    if grid is None or len(grid.data) != grid.info.width * grid.info.height or grid.info.width == 0:
        fail("/map", "no occupancy grid, or its size is not width x height")
    if not set(int(v) for v in set(grid.data.tolist())) <= {-1, 0, 100}:
        fail("/map", "cells other than -1, 0, 100")
    return base


def read_foxglove(path):
    from mcap.decoder import DecoderFactory as McapDecoderFactory
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    class Json(McapDecoderFactory):
        def decoder_for(self, message_encoding, schema):
            if message_encoding == "json":
                return lambda data: json.loads(data)
            return None

    out = defaultdict(list)
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory(), Json()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
            out[channel.topic].append((message.log_time, decoded))
    return out


def same_times(topic, ros, fox):
    if [t for t, _ in ros] != [t for t, _ in fox]:
        fail(topic, f"{len(ros)} messages here, {len(fox)} in the Foxglove recording, or at other times")


def pose_values(p):
    return (p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w)


def short(v):
    text = repr(v)
    return text if len(text) <= 160 else text[:160] + "..."


def equal(topic, t, what, a, b):
    if a != b:
        fail(topic, f"at {t} ns: {what} {short(a)} here, {short(b)} in the Foxglove recording")


def as_f32(values):
    return list(struct.unpack(f"<{len(values)}f", struct.pack(f"<{len(values)}f", *values)))


def compare(messages, types, fox):
    compared = Counter()
    for topic, msgtype in types.items():
        ros = messages[topic]
        if topic.startswith("/scan/"):
            same_times(topic, ros, fox[topic])
            exact = messages.get("/atrium/ranges/" + topic[len("/scan/"):], [])
            same_times("/atrium/ranges/" + topic[len("/scan/"):], exact, fox[topic])
            for (t, m), (_, f), (_, e) in zip(ros, fox[topic], exact):
                # REP 117: a beam with no return (range_max in the Foxglove recording) is +Inf.
                short = [math.inf if r >= float(m.range_max) else r for r in as_f32(list(f.ranges))]
                equal(topic, t, "ranges (float32)", m.ranges.tolist(), short)
                equal(topic, t, "exact ranges", e.ranges.tolist(), list(f.ranges))
                equal(topic, t, "frame", m.header.frame_id, f.frame_id)
                equal(topic, t, "angle_min", float(m.angle_min), as_f32([f.start_angle])[0])
        elif msgtype == "sensor_msgs/msg/Image":
            same_times(topic, ros, fox[topic])
            for (t, m), (_, f) in zip(ros, fox[topic]):
                equal(topic, t, "encoding", m.encoding, f.encoding)
                equal(topic, t, "size", (m.width, m.height, m.step), (f.width, f.height, f.step))
                equal(topic, t, "pixels", bytes(m.data), bytes(f.data))
        elif topic in ("/odom", "/ground_truth") or topic.startswith("/estimate/"):
            same_times(topic, ros, fox[topic])
            for (t, m), (_, f) in zip(ros, fox[topic]):
                equal(topic, t, "pose", pose_values(m.pose.pose), pose_values(f.pose))
        elif topic == "/odom/wheels":
            same_times(topic, ros, fox[topic])
            for (t, m), (_, f) in zip(ros, fox[topic]):
                equal(topic, t, "pose", (m.x, m.y, m.theta), (f["pose"]["x"], f["pose"]["y"], f["pose"]["theta"]))
                equal(topic, t, "ticks", (m.left_ticks, m.right_ticks), (f["left_ticks"], f["right_ticks"]))
        elif topic == "/atrium/score":
            same_times(topic, ros, fox[topic])
            for (t, m), (_, f) in zip(ros, fox[topic]):
                equal(topic, t, "instant", (m.t, m.x, m.y, m.theta), (f["t"], f["x"], f["y"], f["theta"]))
        elif topic.startswith("/wifi/"):
            same_times(topic, ros, fox[topic])
            for (t, m), (_, f) in zip(ros, fox[topic]):
                here = [(r.ap, r.channel, r.rssi_dbm) for r in m.readings]
                there = [(r["ap"], r["channel"], r["rssi_dbm"]) for r in f["readings"]]
                equal(topic, t, "readings", here, there)
        elif topic.startswith("/landmarks/"):
            same_times(topic, ros, fox[topic])
            for (t, m), (_, f) in zip(ros, fox[topic]):
                here = [(d.range, d.bearing, d.id if d.id >= 0 else None) for d in m.detections]
                there = [(d["range"], d["bearing"], d.get("id")) for d in f["detections"]]
                equal(topic, t, "detections", here, there)
        elif topic == "/tf":
            # The Foxglove /tf also holds the static frames and map -> odom; compare odom ->
            # base, the per-reading transform both carry.
            dynamic = [(t, f) for t, f in fox[topic] if any(x.parent_frame_id == "odom" for x in f.transforms)]
            same_times(topic, ros, dynamic)
            for (t, m), (_, f) in zip(ros, dynamic):
                here = [(x.header.frame_id, x.child_frame_id, x.transform.translation.x, x.transform.translation.y, x.transform.rotation.z, x.transform.rotation.w) for x in m.transforms if x.header.frame_id == "odom"]
                there = [(x.parent_frame_id, x.child_frame_id, x.translation.x, x.translation.y, x.rotation.z, x.rotation.w) for x in f.transforms if x.parent_frame_id == "odom"]
                equal(topic, t, "transforms", here, there)
        else:
            continue
        compared[topic] = len(ros)
    return compared


DURABILITY = {"transient local": QosDurability.TRANSIENT_LOCAL, "volatile": QosDurability.VOLATILE}


def doc_rows(doc):
    """The table under "## What this walk-through relies on" in docs/ros2.md."""
    text = Path(doc).read_text()
    section = text.split("## What this walk-through relies on", 1)
    if len(section) != 2:
        raise Failed(f"{doc}: no section 'What this walk-through relies on'")
    rows = []
    for line in section[1].splitlines():
        if line.startswith("| `/"):
            cells = [c.strip().strip("`") for c in line.strip().strip("|").split("|")]
            if len(cells) != 5:
                raise Failed(f"{doc}: row {line!r} has {len(cells)} cells, expected 5")
            rows.append(cells)
    if len(rows) < 8:
        raise Failed(f"{doc}: {len(rows)} rows in the table")
    return rows


def check_doc(path, doc, messages, types):
    """Every row and promise of the walk-through, read with rosbags."""
    qos = {}
    with Reader(path) as reader:
        for conn in reader.connections:
            qos[conn.topic] = [q.durability for q in conn.ext.offered_qos_profiles]
    for topic, msgtype, frame, child, durability in doc_rows(doc):
        if topic not in types:
            fail(topic, f"named in {doc} but not in the bag")
        if types[topic] != msgtype:
            fail(topic, f"type {types[topic]}, {doc} says {msgtype}")
        if not qos[topic] or any(d != DURABILITY[durability] for d in qos[topic]):
            fail(topic, f"offered durability {qos[topic]}, {doc} says {durability}")
        msgs = [m for _, m in messages[topic]]
        if msgtype == "tf2_msgs/msg/TFMessage":
            if not any(t.header.frame_id == frame and t.child_frame_id == child for m in msgs for t in m.transforms):
                fail(topic, f"no transform {frame} -> {child}, which {doc} relies on")
        elif frame:
            for m in msgs:
                if m.header.frame_id != frame or (child and m.child_frame_id != child):
                    fail(topic, f"frames {m.header.frame_id!r} / {getattr(m, 'child_frame_id', None)!r}, {doc} says {frame!r} / {child!r}")
    odom = [m for _, m in messages["/odom"]]
    if not any(abs(m.twist.twist.linear.x) > 0.05 for m in odom):
        fail("/odom", "the twist is zero in every message")
    for k, m in enumerate(odom[1:], 1):
        pc, tc = m.pose.covariance, m.twist.covariance
        if not (tc[0] > 0 and tc[35] > 0 and pc[0] >= 0 and pc[35] >= 0):
            fail("/odom", f"message {k}: covariances {pc.tolist()} / {tc.tolist()}")
    if not (odom[-1].pose.covariance[0] > 0 and odom[-1].pose.covariance[35] > 0):
        fail("/odom", "the pose covariance did not grow over the drive")
    for topic, msgtype in types.items():
        if msgtype != "sensor_msgs/msg/LaserScan":
            continue
        scans = [m for _, m in messages[topic]]
        if not any(math.isinf(r) and r > 0 for m in scans for r in m.ranges.tolist()):
            fail(topic, "no +Inf beam (REP 117)")
        for m in scans:
            if not (0 < m.range_min < m.range_max and m.scan_time > 0 and m.time_increment > 0):
                fail(topic, f"range_min {m.range_min}, range_max {m.range_max}, scan_time {m.scan_time}, time_increment {m.time_increment}")
            if any(r >= m.range_max and not math.isinf(r) for r in m.ranges.tolist()):
                fail(topic, "a beam at range_max instead of +Inf")
    grid = messages["/map"][0][1]
    if -1 not in set(int(v) for v in set(grid.data.tolist())):
        fail("/map", "no unknown (-1) cells")
    names = set(messages["/joint_states"][-1][1].name)
    for joint in ("left_wheel_joint", "right_wheel_joint"):
        if joint not in names:
            fail("/joint_states", f"no {joint} (has {sorted(names)})")


def main() -> int:
    args = sys.argv[1:]
    if not args:
        print(__doc__, file=sys.stderr)
        return 2
    path = Path(args.pop(0))
    foxglove = None
    doc = None
    tf_ground_truth = False
    minimum = {}
    while args:
        arg = args.pop(0)
        if arg == "--foxglove":
            foxglove = args.pop(0)
        elif arg == "--doc":
            doc = args.pop(0)
        elif arg == "--tf-ground-truth":
            tf_ground_truth = True
        else:
            topic, count = arg.rsplit("=", 1)
            minimum[topic] = int(count)
    try:
        messages, types = read_bag(path)
        base = check_frames(messages, types, tf_ground_truth)
        if doc:
            check_doc(path, doc, messages, types)
        for topic, need in minimum.items():
            if len(messages.get(topic, [])) < need:
                fail(topic, f"{len(messages.get(topic, []))} messages, expected at least {need}")
        compared = compare(messages, types, read_foxglove(foxglove)) if foxglove else Counter()
        if foxglove:
            for prefix in ("/scan/", "/odom", "/ground_truth", "/estimate/", "/atrium/score", "/tf"):
                if not any(t.startswith(prefix) for t in compared):
                    fail(prefix, "nothing compared with the Foxglove recording")
    except Failed as e:
        print(f"{path}: {e}", file=sys.stderr)
        return 1
    for topic in sorted(types):
        mark = "= foxglove" if topic in compared else ""
        print(f"{topic:34} {types[topic]:46} {len(messages[topic]):6} {mark}")
    print(f"base link {base}; {sum(len(v) for v in messages.values())} messages deserialized and re-serialized")
    return 0


if __name__ == "__main__":
    sys.exit(main())
