#!/usr/bin/env python3
"""Writes the small log fixtures of `datasets/fixtures/` from the bundled fr079 ROS 1 bag, with
the independent `rosbags` package (pip install rosbags==0.11.*), so that Atrium's readers are
tested on files written by another tool in each storage and compression it reads:

- fr079_head_lz4.bag: ROS 1 bag with lz4 chunks (the bundled bag has bz2 chunks);
- fr079_head_sqlite3/: rosbag2 folder with sqlite3 storage (the bundled one is MCAP).

Both hold the first 60 s of the log (every topic). Run from the repository root:
    python3 scripts/make_log_fixtures.py
"""
import shutil
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import Writer as Writer2, StoragePlugin
from rosbags.typesys import Stores, get_typestore

SOURCE = Path("datasets/fr079/fr079.orig.bag")
OUT = Path("datasets/fixtures")
SECONDS = 60.0


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    lz4 = OUT / "fr079_head_lz4.bag"
    sqlite = OUT / "fr079_head_sqlite3"
    for p in (lz4,):
        p.unlink(missing_ok=True)
    shutil.rmtree(sqlite, ignore_errors=True)
    ros2 = get_typestore(Stores.ROS2_HUMBLE)
    with AnyReader([SOURCE]) as reader:
        start = reader.start_time
        end = start + int(SECONDS * 1e9)
        w1 = Writer1(lz4)
        w1.set_compression(Writer1.CompressionFormat.LZ4)
        with w1, Writer2(sqlite, version=8, storage_plugin=StoragePlugin.SQLITE3) as w2:
            out1, out2 = {}, {}
            for con, t, raw in reader.messages():
                if t > end:
                    continue
                if con.topic not in out1:
                    out1[con.topic] = w1.add_connection(
                        con.topic, con.msgtype, msgdef=con.msgdef.data, md5sum=con.digest,
                        callerid=con.ext.callerid, latching=con.ext.latching)
                    out2[con.topic] = w2.add_connection(con.topic, con.msgtype, typestore=ros2)
                w1.write(out1[con.topic], t, raw)
                msg = reader.deserialize(raw, con.msgtype)
                w2.write(out2[con.topic], t, ros2.serialize_cdr(msg, con.msgtype))


if __name__ == "__main__":
    main()
