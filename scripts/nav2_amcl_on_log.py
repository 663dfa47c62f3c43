#!/usr/bin/env python3
"""nav2's AMCL (the PyPI `amcl` package, a wrapper of nav2_amcl's particle filter, motion
model and laser models) on a real log, for the peer comparison in BENCHMARKS.md.

It reads the log with the independent `rosbags` reader (not Atrium's), the map with its own
ROS map_server YAML/PGM code, and feeds AMCL as nav2's amcl_node does: an update when the
odometry has moved `--update-min-d` metres or turned `--update-min-a` radians since the last
one (nav2's defaults 0.25 and 0.2), the pose between updates being the last estimate carried
by the odometry (the map->odom transform nav2 publishes). It writes a TUM trajectory with one
pose per scan, in the log's stamps, for `atrium score SCENARIO.toml OUT.tum`, and prints the
time per update.

    python3 scripts/nav2_amcl_on_log.py datasets/fr079/fr079_ros2 \
        --map datasets/fr079/fr079_map.yaml --reference datasets/fr079/fr079_reference.tum \
        -o target/nav2_amcl_fr079.tum

Parameters are nav2's defaults (alpha1..4 0.2, z_hit 0.5, z_rand 0.5, sigma_hit 0.2,
max_beams 60, 500..2000 particles, no recovery injection); the wrapper exposes nav2's beam
model only (nav2's default is the likelihood field), so the comparison is run on both of
Atrium's models. The estimate is the particle set's weighted mean, which the wrapper returns.
"""
import argparse
import bisect
import json
import math
import os
import sys
import time


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap(a[2] + b[2]))


def inverse(a):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2])


def interpolate(track, stamps, t):
    i = bisect.bisect_left(stamps, t)
    if i == 0:
        return track[0][1]
    if i >= len(track):
        return track[-1][1]
    (t0, a), (t1, b) = track[i - 1], track[i]
    f = (t - t0) / (t1 - t0)
    return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), wrap(a[2] + f * wrap(b[2] - a[2])))


def read_map(yaml_path):
    meta = {}
    for line in open(yaml_path):
        line = line.split("#")[0].strip()
        if ":" in line:
            k, v = line.split(":", 1)
            meta[k.strip()] = v.strip().strip('"')
    res = float(meta["resolution"])
    ox, oy = [float(x) for x in meta["origin"].strip("[]").split(",")[:2]]
    negate = int(meta.get("negate", "0"))
    occ_t, free_t = float(meta.get("occupied_thresh", 0.65)), float(meta.get("free_thresh", 0.196))
    path = os.path.join(os.path.dirname(yaml_path), meta["image"])
    data = open(path, "rb").read()
    # Binary PGM (P5), 8 bit: header fields separated by whitespace.
    fields, pos = [], 2
    assert data[:2] == b"P5", f"{path}: only binary PGM (P5) is read here"
    while len(fields) < 3:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos)
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(int(data[pos:end]))
        pos = end
    w, h, _ = fields
    pixels = data[pos + 1:pos + 1 + w * h]
    rows = []
    for j in range(h):  # grid row j is the image row h-1-j (the image's top is +y)
        row = pixels[(h - 1 - j) * w:(h - j) * w]
        out = []
        for v in row:
            p = v / 255.0 if negate else (255 - v) / 255.0
            out.append(100 if p > occ_t else (0 if p < free_t else -1))
        rows.append(out)
    return rows, res, ox, oy


def read_tum(path):
    out = []
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        v = [float(x) for x in line.split()]
        qx, qy, qz, qw = v[4:8]
        out.append((v[0], (v[1], v[2], math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz)))))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("bag")
    ap.add_argument("--map", required=True)
    ap.add_argument("--reference", required=True, help="TUM; its pose at the first scan starts AMCL")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--scan-topic", default="/scan")
    ap.add_argument("--odom-topic", default="/odom")
    ap.add_argument("--update-min-d", type=float, default=0.25)
    ap.add_argument("--update-min-a", type=float, default=0.2)
    ap.add_argument("--initial-sigma", type=float, nargs=3, default=[0.1, 0.1, 0.05])
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()

    import amcl
    from rosbags.highlevel import AnyReader
    from pathlib import Path

    scans, odom, mount = [], [], (0.0, 0.0, 0.0)
    with AnyReader([Path(a.bag)]) as reader:
        for conn, stamp, raw in reader.messages():
            if conn.topic not in (a.scan_topic, a.odom_topic, "/tf_static"):
                continue
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic == a.scan_topic:
                t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
                scans.append((t, msg))
            elif conn.topic == a.odom_topic:
                t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
                p = msg.pose.pose
                odom.append((t, (p.position.x, p.position.y, yaw_of(p.orientation))))
            else:
                for tf in msg.transforms:
                    if scans and tf.child_frame_id != scans[0][1].header.frame_id:
                        continue
                    tr = tf.transform.translation
                    mount = (tr.x, tr.y, yaw_of(tf.transform.rotation))
    scans.sort(key=lambda s: s[0])
    odom.sort(key=lambda o: o[0])
    ostamps = [t for t, _ in odom]

    rows, res, ox, oy = read_map(a.map)
    grid = amcl.create_occupancy_grid_from_list(rows, res, ox, oy)
    motion = amcl.MotionParameters(alpha1=0.2, alpha2=0.2, alpha3=0.2, alpha4=0.2, alpha5=0.2)
    laser = amcl.LaserParameters(z_hit=0.5, z_short=0.05, z_max=0.05, z_rand=0.5, sigma_hit=0.2,
                                 lambda_short=0.1, chi_outlier=0.0, max_beams=60)
    pf = amcl.AMCL(500, 2000, 0.0, 0.0, motion, laser, "differential")
    pf.set_map(grid)
    pf.set_laser_pose(amcl.Vector3D(*mount))

    ref = read_tum(a.reference)
    rstamps = [t for t, _ in ref]
    t_first = scans[0][0]
    start = interpolate(ref, rstamps, t_first)
    cov = amcl.Matrix3D()
    cov.set(0, 0, a.initial_sigma[0] ** 2)
    cov.set(1, 1, a.initial_sigma[1] ** 2)
    cov.set(2, 2, a.initial_sigma[2] ** 2)
    pf.set_initial_pose(amcl.Vector3D(*start), cov)

    out, last_odom, map_odom = [], None, None
    updates, busy = 0, 0.0
    for t, msg in scans:
        o = interpolate(odom, ostamps, t)
        moved = last_odom is None or (
            math.hypot(o[0] - last_odom[0], o[1] - last_odom[1]) >= a.update_min_d
            or abs(wrap(o[2] - last_odom[2])) >= a.update_min_a)
        if moved:
            rmax = msg.range_max
            pairs = []
            for i, r in enumerate(msg.ranges):
                r = float(r)
                if not math.isfinite(r) or r <= msg.range_min or r > rmax:
                    r = rmax  # as nav2's amcl_node: no-return and too-short beams read max
                pairs.append([r, msg.angle_min + i * msg.angle_increment])
            scan = amcl.create_laser_scan_from_list(pairs, rmax)
            t0 = time.perf_counter()
            pf.update(scan, amcl.Vector3D(*o))
            busy += time.perf_counter() - t0
            updates += 1
            m = pf.get_pose_mean()
            est = (m.x, m.y, m.theta)
            map_odom = compose(est, inverse(o))
            last_odom = o
        est = compose(map_odom, o)
        out.append((t, est))

    tmp = a.output + ".partial"
    with open(tmp, "w") as f:
        f.write("# nav2 AMCL (PyPI amcl) on %s: timestamp x y z qx qy qz qw\n" % a.bag)
        for t, (x, y, th) in out:
            f.write("%.9f %.6f %.6f 0 0 0 %.9f %.9f\n" % (t, x, y, math.sin(th / 2), math.cos(th / 2)))
    os.replace(tmp, a.output)
    summary = {"scans": len(scans), "updates": updates, "update_ms_mean": 1e3 * busy / max(updates, 1),
               "busy_s": busy, "log_s": scans[-1][0] - scans[0][0],
               "real_time_factor": (scans[-1][0] - scans[0][0]) / max(busy, 1e-9), "laser_mount": mount}
    print(json.dumps(summary, indent=2) if a.json else
          "%d updates of %d scans, %.2f ms per update, %.0fx real time (updates only)" % (
              updates, len(scans), summary["update_ms_mean"], summary["real_time_factor"]),
          file=sys.stdout if a.json else sys.stderr)


if __name__ == "__main__":
    main()
