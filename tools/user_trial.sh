#!/usr/bin/env bash
# The first hour of a new user (issue 41's trial), run from an empty folder outside the repository with no
# display: each command, the exit code it gave and the one it should give, its time and its last stderr
# line. Run it against an installed wheel to check the distribution, not the clone:
#
#   python3 -m venv /tmp/wv && /tmp/wv/bin/pip install "dist/nxtnav-0.1.0-py3-none-any.whl[nxt,viz]"
#   bash tools/user_trial.sh /tmp/wv/bin/nxtnav
#
# Exit status 1 when any command's exit code is not the one wanted.
set -u
N=${1:-nxtnav}
cd "$(mktemp -d)" || exit 1
unset DISPLAY WAYLAND_DISPLAY WAYLAND_SOCKET NXTNAV_MAPS PYTHONPATH
total=0 wrong=0
t() {
    local want=$1 t0=$SECONDS rc
    shift
    "$@" > out.txt 2> err.txt
    rc=$?
    total=$((total + 1))
    [ "$rc" -eq "$want" ] || wrong=$((wrong + 1))
    printf '%s exit %s (want %s) %3ss  %s\n    %s\n' "$([ "$rc" -eq "$want" ] && echo ok || echo NO)" "$rc" "$want" \
        "$((SECONDS - t0))" "${*:2}" "$(grep -v '^\s*$' err.txt | tail -1 | cut -c1-140)"
}
t 0 "$N" run --map map1 --localiser amcl --record run.jsonl
t 0 "$N" replay run.jsonl --localisers amcl,paper-pf,pf-systematic -o replay.png
t 0 "$N" import sweeps maps/real-nxt -o real-nxt.jsonl
t 0 "$N" replay real-nxt.jsonl --localisers paper-pf,amcl --json real-nxt.json
t 2 "$N" run --view
t 2 "$N" view run.jsonl
t 0 "$N" view run.jsonl --save run.rrd
t 0 "$N" import bag maps/jarvis/jarvis_circular_path_fast.bag --map maps/jarvis/i-108_10mm.yaml \
    --scan-topic /driver_laser_navigation/laser_scan --truth-topic /pose_ground_truth \
    --truth-frame 1460.64,334.25,-1.536 --beams 120 --every 20 --scan-delay 0.125 -o jarvis.jsonl
t 2 "$N" run --plot /proc/x.png
t 2 "$N" export run.jsonl --mcap /proc/bag
head -c 20000 run.jsonl > cut.jsonl
t 0 "$N" export cut.jsonl --mcap cutbag
t 0 "$N" export run.jsonl --mcap bag
t 0 "$N" import bag bag --map map1 --scan-topic /scan --truth-topic /ground_truth --no-deskew -o back.jsonl
t 0 "$N" replay back.jsonl --localisers amcl
t 2 "$N" localise --map map1 --pose 20,85,0 --sonar pigeon
t 0 "$N" plan --map map1 --planner astar -o plan.png
t 0 "$N" maps list --json
t 0 "$N" planners show min-turn --json
t 0 "$N" localisers show amcl --json
echo "$((total - wrong)) of $total commands gave the exit code wanted"
[ "$wrong" -eq 0 ]
