#!/usr/bin/env python3
"""A small laser particle filter for Atrium, in plain Python (standard library only).

It speaks Atrium's process-localizer protocol, version 1 (docs/protocol.md): one JSON object
per line on stdin, one answer line on stdout per message; diagnostics go to stderr, which
Atrium keeps with the run (``log_<name>.txt`` with ``--out``).

The filter: particles drawn around the tracking belief; the odometry motion model
(Probabilistic Robotics, table 5.6) applied when the robot has moved enough; a likelihood
field built from the hello's vector map weighs a subsample of each scan's beams; low-variance
resampling when the effective sample size drops. Between filter updates it answers the last
mean carried forward by odometry.

Parameters (the localizer's ``params = { ... }`` in the scenario), all optional:

  particles       number of particles (300)
  beams           beams used per scan, evenly spaced (30)
  sigma_hit       likelihood-field standard deviation, m (0.15)
  z_rand          weight of the uniform part of the beam likelihood (0.05)
  alpha           odometry noise [rot/rot, rot/trans, trans/trans, trans/rot] (0.1, 0.05, 0.05, 0.1)
  update_min_d    translation between filter updates, m (0.10)
  update_min_a    rotation between filter updates, rad (0.10)
  field_resolution   likelihood-field cell size, m (0.05)
  field_max_dist     distances beyond this are clipped, m (0.6)

For testing Atrium's failure handling only (counted in messages after the hello):

  exit_after      exit with status 3 on message N
  kill_after      kill itself with SIGKILL on message N
  garbage_after   print a line that is not JSON instead of answering message N
  nan_after       answer message N with a NaN pose
  hang_after      stop answering at message N (sleep)
"""

import json
import math
import os
import random
import signal
import sys
import time
from collections import deque

PROTOCOL = 1


def log(*args):
    print("particle_filter:", *args, file=sys.stderr, flush=True)


def send(obj):
    sys.stdout.write(json.dumps(obj, allow_nan=True) + "\n")
    sys.stdout.flush()


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def relative(a, b):
    """Pose b in the frame of pose a (a^-1 (+) b)."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    c, s = math.cos(a[2]), math.sin(a[2])
    return (c * dx + s * dy, -s * dx + c * dy, wrap(b[2] - a[2]))


def compose(a, d):
    """a (+) d."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * d[0] - s * d[1], a[1] + s * d[0] + c * d[1], wrap(a[2] + d[2]))


class LikelihoodField:
    """log(z_hit * N(d; 0, sigma) + z_rand) per cell, d the distance to the nearest wall of
    the vector map (a brushfire from the rasterised segments, clipped at max_dist)."""

    def __init__(self, segments, resolution, max_dist, sigma, z_rand):
        self.res = resolution
        xs = [v for s in segments for v in (s[0], s[2])]
        ys = [v for s in segments for v in (s[1], s[3])]
        self.ox = min(xs) - max_dist - resolution
        self.oy = min(ys) - max_dist - resolution
        self.w = int((max(xs) - self.ox + max_dist) / resolution) + 2
        self.h = int((max(ys) - self.oy + max_dist) / resolution) + 2
        w, h = self.w, self.h
        inf = float("inf")
        dist = [inf] * (w * h)
        near = [0] * (w * h)  # index of the nearest occupied cell
        queue = deque()
        for x1, y1, x2, y2 in segments:
            n = int(math.hypot(x2 - x1, y2 - y1) / (0.5 * resolution)) + 1
            for k in range(n + 1):
                f = k / n
                i = int((x1 + f * (x2 - x1) - self.ox) / resolution)
                j = int((y1 + f * (y2 - y1) - self.oy) / resolution)
                c = j * w + i
                if dist[c] != 0.0:
                    dist[c] = 0.0
                    near[c] = c
                    queue.append(c)
        limit = (max_dist / resolution) ** 2
        steps = [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)]
        while queue:
            c = queue.popleft()
            j, i = divmod(c, w)
            o = near[c]
            oj, oi = divmod(o, w)
            for di, dj in steps:
                ni, nj = i + di, j + dj
                if 0 <= ni < w and 0 <= nj < h:
                    n = nj * w + ni
                    d2 = (ni - oi) ** 2 + (nj - oj) ** 2
                    if d2 <= limit and d2 < dist[n]:
                        dist[n] = d2
                        near[n] = o
                        queue.append(n)
        inv = 1.0 / (2.0 * sigma * sigma)
        r2 = resolution * resolution
        z_hit = 1.0 - z_rand
        far = math.log(z_hit * math.exp(-(max_dist ** 2) * inv) + z_rand)
        self.table = [
            far if d == inf else math.log(z_hit * math.exp(-d * r2 * inv) + z_rand)
            for d in dist
        ]
        self.outside = far


class ParticleFilter:
    def __init__(self, hello, params):
        belief = hello["initial_belief"]
        if belief["mode"] != "tracking":
            raise ValueError("this example filter needs a tracking initial belief (mode = \"tracking\")")
        self.rng = random.Random(hello["seed"])
        self.n = int(params.get("particles", 300))
        self.beams = int(params.get("beams", 30))
        self.alpha = [float(a) for a in params.get("alpha", [0.1, 0.05, 0.05, 0.1])]
        self.min_d = float(params.get("update_min_d", 0.10))
        self.min_a = float(params.get("update_min_a", 0.10))
        started = time.perf_counter()
        self.field = LikelihoodField(
            hello["map"]["vector"],
            float(params.get("field_resolution", 0.05)),
            float(params.get("field_max_dist", 0.6)),
            float(params.get("sigma_hit", 0.15)),
            float(params.get("z_rand", 0.05)),
        )
        log(
            f"{self.n} particles, {self.beams} beams, likelihood field "
            f"{self.field.w}x{self.field.h} built in {time.perf_counter() - started:.2f} s"
        )
        x, y, th = belief["pose"]
        sx, sy, sth = belief["sigma"]
        g = self.rng.gauss
        self.particles = [
            (x + g(0, sx), y + g(0, sy), wrap(th + g(0, sth))) for _ in range(self.n)
        ]
        self.weights = [1.0 / self.n] * self.n
        self.mean = (x, y, th)
        self.cov = [sx * sx, 0, 0, 0, sy * sy, 0, 0, 0, sth * sth]
        self.odom_ref = None  # odometry pose at the last filter update
        self.odom_now = None
        self.updates = 0

    # --- motion ---------------------------------------------------------------------------

    def odometry(self, frm, to):
        if self.odom_ref is None:
            self.odom_ref = tuple(frm)
        self.odom_now = tuple(to)

    def pending(self):
        if self.odom_ref is None:
            return (0.0, 0.0, 0.0)
        return relative(self.odom_ref, self.odom_now)

    def estimate(self):
        """The last mean carried forward by the odometry since."""
        return compose(self.mean, self.pending())

    def move_particles(self, d):
        dx, dy, dth = d
        trans = math.hypot(dx, dy)
        rot1 = math.atan2(dy, dx) if trans > 0.01 else 0.0
        if abs(wrap(rot1)) > math.pi / 2:  # driving backwards
            rot1 = wrap(rot1 + math.pi)
            trans = -trans
        rot2 = wrap(dth - rot1)
        a1, a2, a3, a4 = self.alpha
        s_r1 = math.sqrt(a1 * rot1 * rot1 + a2 * trans * trans)
        s_t = math.sqrt(a3 * trans * trans + a4 * (rot1 * rot1 + rot2 * rot2))
        s_r2 = math.sqrt(a1 * rot2 * rot2 + a2 * trans * trans)
        g = self.rng.gauss
        moved = []
        for x, y, th in self.particles:
            r1 = rot1 + g(0, s_r1)
            t = trans + g(0, s_t)
            r2 = rot2 + g(0, s_r2)
            a = th + r1
            moved.append((x + t * math.cos(a), y + t * math.sin(a), wrap(a + r2)))
        self.particles = moved

    # --- measurement ----------------------------------------------------------------------

    def laser(self, m):
        d = self.pending()
        if self.updates > 0 and math.hypot(d[0], d[1]) < self.min_d and abs(d[2]) < self.min_a:
            return
        self.move_particles(d)
        self.odom_ref = self.odom_now
        ranges = m["ranges"]
        step = max(1, len(ranges) // self.beams)
        mx, my, mth = m["mount"]
        a0, da = m["angle_min"], m["angle_increment"]
        lo, hi = m["range_min"], m["range_max"] - 1e-3
        # Beam end points in the robot frame.
        ends = []
        for k in range(0, len(ranges), step):
            r = ranges[k]
            if lo <= r < hi:
                a = mth + a0 + k * da
                ends.append((mx + r * math.cos(a), my + r * math.sin(a)))
        if not ends:
            return
        f = self.field
        table, outside, w, h = f.table, f.outside, f.w, f.h
        inv, ox, oy = 1.0 / f.res, f.ox, f.oy
        logw = []
        for x, y, th in self.particles:
            c, s = math.cos(th), math.sin(th)
            total = 0.0
            for bx, by in ends:
                i = int((x + c * bx - s * by - ox) * inv)
                j = int((y + s * bx + c * by - oy) * inv)
                if 0 <= i < w and 0 <= j < h:
                    total += table[j * w + i]
                else:
                    total += outside
            logw.append(total)
        top = max(logw)
        weights = [wt * math.exp(lw - top) for wt, lw in zip(self.weights, logw)]
        norm = sum(weights)
        self.weights = [wt / norm for wt in weights]
        self.updates += 1
        self.summarise()
        n_eff = 1.0 / sum(wt * wt for wt in self.weights)
        if n_eff < 0.5 * self.n:
            self.resample()

    def resample(self):
        """Low-variance resampling (Probabilistic Robotics, table 4.4)."""
        n = self.n
        r = self.rng.random() / n
        c = self.weights[0]
        i = 0
        out = []
        for m in range(n):
            u = r + m / n
            while u > c and i < n - 1:
                i += 1
                c += self.weights[i]
            out.append(self.particles[i])
        self.particles = out
        self.weights = [1.0 / n] * n

    def summarise(self):
        ws, ps = self.weights, self.particles
        x = sum(w * p[0] for w, p in zip(ws, ps))
        y = sum(w * p[1] for w, p in zip(ws, ps))
        th = math.atan2(sum(w * math.sin(p[2]) for w, p in zip(ws, ps)),
                        sum(w * math.cos(p[2]) for w, p in zip(ws, ps)))
        cov = [0.0] * 9
        for w, p in zip(ws, ps):
            e = (p[0] - x, p[1] - y, wrap(p[2] - th))
            for a in range(3):
                for b in range(3):
                    cov[3 * a + b] += w * e[a] * e[b]
        self.mean = (x, y, th)
        self.cov = cov


def main():
    hello = json.loads(sys.stdin.readline())
    if PROTOCOL not in hello.get("protocols", [hello.get("protocol")]):
        send({"type": "error", "message": f"this filter speaks protocol {PROTOCOL} only"})
        return 1
    params = hello.get("params", {})
    try:
        pf = ParticleFilter(hello, params)
    except (ValueError, KeyError) as e:
        send({"type": "error", "message": str(e)})
        return 1
    send({"type": "hello", "protocol": PROTOCOL, "subscribe": ["laser"],
          "pose": list(pf.mean), "covariance": pf.cov})
    debug = {k: int(params[k]) for k in
             ("exit_after", "kill_after", "garbage_after", "nan_after", "hang_after") if k in params}
    started = time.perf_counter()
    n = 0
    next_report = 10.0
    while True:
        line = sys.stdin.readline()
        if not line:
            log("stdin closed before bye")
            return 1
        m = json.loads(line)
        kind = m["type"]
        if kind == "bye":
            break
        n += 1
        if debug.get("exit_after") == n:
            log(f"exit_after = {n}: exiting with status 3 on message {n} ({kind})")
            return 3
        if debug.get("kill_after") == n:
            log(f"kill_after = {n}: killing myself with SIGKILL on message {n} ({kind})")
            os.kill(os.getpid(), signal.SIGKILL)
        if debug.get("garbage_after") == n:
            log(f"garbage_after = {n}: answering message {n} ({kind}) with garbage")
            sys.stdout.write("garbage, not JSON\n")
            sys.stdout.flush()
            continue
        if debug.get("hang_after") == n:
            log(f"hang_after = {n}: not answering message {n} ({kind})")
            time.sleep(3600)
        if kind == "odometry":
            pf.odometry(m["from"], m["to"])
        elif kind == "laser":
            pf.laser(m)
        pose = list(pf.estimate())
        if debug.get("nan_after") == n:
            pose[0] = float("nan")
        send({"type": "estimate", "t": m["t"], "pose": pose, "covariance": pf.cov})
        if m["t"] >= next_report:
            log(f"t = {m['t']:.1f} s: pose ({pose[0]:.2f}, {pose[1]:.2f}, {pose[2]:.2f}), "
                f"{pf.updates} updates")
            next_report += 10.0
    log(f"bye after {n} messages, {pf.updates} filter updates, "
        f"{time.perf_counter() - started:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
