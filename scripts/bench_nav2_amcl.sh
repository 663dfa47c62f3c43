#!/usr/bin/env bash
# Atrium's MCL beside nav2's AMCL (the PyPI `amcl` wrapper of nav2_amcl) on a bundled real log,
# in one run: accuracy against the reference and the benchmark relations, and time per update.
# The figures of BENCHMARKS.md "Real logs: Atrium MCL beside nav2 AMCL".
#
#   scripts/bench_nav2_amcl.sh [fr079|mit]        (default fr079)
set -euo pipefail
cd "$(dirname "$0")/.."
which=${1:-fr079}
case "$which" in
  fr079) scenario=scenarios/fr079_real.toml; log=datasets/fr079/fr079_ros2
         map=datasets/fr079/fr079_map.yaml; ref=datasets/fr079/fr079_reference.tum ;;
  *) echo "usage: $0 [fr079]  (the nav2 driver reads ROS bags with rosbags)" >&2; exit 2 ;;
esac
venv=target/nav2-venv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet amcl==0.1.2 'rosbags==0.11.*'
fi
cargo build --release --locked -p atrium-cli >/dev/null
out=target/bench-nav2-$which
mkdir -p "$out"
# Atrium: MCL alone (the scenario's other localizers would share the machine).
python3 - "$scenario" "$out/mcl_only.toml" <<'EOF'
import sys, re
s = open(sys.argv[1]).read()
head = s[:s.index("[[localizers]]")]
head = re.sub(r'"\.\./', '"' + __import__("os").path.abspath("scenarios/..") + "/", head)
open(sys.argv[2], "w").write(head + '[[localizers]]\nname = "mcl"\nkind = "mcl"\n')
EOF
./target/release/atrium run "$out/mcl_only.toml" --json > "$out/atrium.json"
"$venv/bin/python" scripts/nav2_amcl_on_log.py "$log" --map "$map" --reference "$ref" \
  -o "$out/nav2_amcl.tum" --json > "$out/nav2_run.json"
./target/release/atrium score "$scenario" "$out/nav2_amcl.tum" --name nav2_amcl --json > "$out/nav2.json" || true
python3 - "$out" <<'EOF'
import json, sys
out = sys.argv[1]
a = json.load(open(f"{out}/atrium.json")); n = json.load(open(f"{out}/nav2.json"))
run = json.load(open(f"{out}/nav2_run.json"))
mcl = a["localizers"][0]; nav = n["localizers"][0]
scans = a["log"]["scans"]; log_s = run["log_s"]
t_mcl = a["timing"]["localizers_s"]["mcl"]
def row(name, l, updates, busy):
    p, r = l["position_error"], l["relations"]
    return (f"| {name} | {p['median']:.3f} | {p['p95']:.2f} | {p['max']:.2f} | "
            f"{r['trans_mean_m']:.3f} ± {r['trans_std_m']:.3f} | {r['rot_mean_deg']:.2f} ± {r['rot_std_deg']:.2f} | "
            f"{updates} | {1e3 * busy / updates:.2f} | {log_s / busy:.0f}× |")
print("| localizer | median m | p95 m | max m | relations trans m | relations rot deg | updates | ms/update | real time |")
print("|---|---|---|---|---|---|---|---|---|")
print(row("Atrium MCL (defaults)", mcl, scans, t_mcl))
print(row("nav2 AMCL (nav2 defaults, beam model)", nav, run["updates"], run["busy_s"]))
EOF
