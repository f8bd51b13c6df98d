#!/bin/sh
# The device run of the per-group floor check (docs/accuracy.md, "Light through openings"):
# from the repository root on the lent GPU machine, with the trimmed Mitsuba wheel in
# .whl/mi.zip and a gzipped release relight binary in .whl/relight.gz.
# - the reference: the grey floor (make_scene.py --grey) path-traced in runs of three light
#   groups, one per colour channel (reference.py --groups-rgb) -> $OUT/reference.tar.gz
# - meanwhile, on the machine's CPUs: relight bakes the same floor in hierarchical mode
#   (0.5 m and 0.25 m, and 0.5 m with per_group_accuracy) and answers each group alone
#   (relight radiosity --json) -> $OUT/answers.tar.gz
# Every step is bounded (STOP_S, default 540 s after the start); what finished comes back.
T0=$(date +%s)
STOP=$(( T0 + ${STOP_S:-540} ))
PY=${PY:-python3}
if [ -z "$LOCAL_TEST" ]; then
    python3 -m zipfile -e .whl/mi.zip /tmp/site
    export PYTHONPATH=/tmp/site
fi
nproc; nvidia-smi --query-gpu=name,memory.total --format=csv,noheader || true
gunzip -c .whl/relight.gz > /tmp/relight && chmod +x /tmp/relight
mkdir -p /tmp/ans /tmp/ref
TIME=""; [ -x /usr/bin/time ] && TIME="/usr/bin/time -v"
$PY benches/floor/make_scene.py /tmp/g50 0.5 --grey
$PY benches/floor/make_scene.py /tmp/g25 0.25 --grey
cp -r /tmp/g50 /tmp/p50
sed -i 's/^units = "m"$/units = "m"\nper_group_accuracy = true/' /tmp/p50/scene.toml
GROUPS=$(grep -A1 '^\[\[lights\]\]' /tmp/g50/scene.toml | sed -n 's/^id = "\(.*\)"/\1/p')
echo "groups: $GROUPS"

answers() {   # answers SCENE NAME: bake (bounded), then each group alone
    left=$(( STOP - $(date +%s) ))
    [ "$left" -gt 30 ] || { echo "$2: no time left" >> /tmp/ans/log; return; }
    s=$(date +%s)
    ( cd /tmp && $TIME timeout "$left" /tmp/relight bake "$1" --cache "/tmp/c-$2" --transfer hierarchical ) \
        > "/tmp/ans/$2.bake.log" 2>&1 || { echo "$2: bake stopped after $(( $(date +%s) - s )) s" >> /tmp/ans/log; return; }
    echo "$2: bake $(( $(date +%s) - s )) s" >> /tmp/ans/log
    for g in $GROUPS; do
        args=""
        for h in $GROUPS; do
            if [ "$h" = "$g" ]; then args="$args --light $h=1"; else args="$args --light $h=0"; fi
        done
        ( cd /tmp && /tmp/relight radiosity "$1" --json --transfer hierarchical --cache "/tmp/c-$2" $args ) \
            > "/tmp/ans/$2.$g.json" 2>> /tmp/ans/log
    done
    echo "$2: answers at $(( $(date +%s) - T0 )) s" >> /tmp/ans/log
}
( answers /tmp/g50 h50; answers /tmp/p50 p50 ) &
( answers /tmp/g25 h25 ) &

set -- $GROUPS
while [ $# -gt 0 ]; do
    run="$1,${2:-},${3:-}"
    shift $(( $# < 3 ? $# : 3 ))
    [ $(( STOP - $(date +%s) )) -gt 60 ] || { echo "reference: no time left for $run"; break; }
    MI_VARIANT=${MI_VARIANT:-cuda_ad_rgb} timeout $(( STOP - $(date +%s) )) $PY benches/floor/reference.py /tmp/g50 /tmp/ref/r \
        --points ${POINTS:-131072} --passes ${PASSES:-8} --no-views --groups-rgb "$run" 2>&1 \
        | grep -a -v 'still being referenced\|jit_\|skipping remainder\|leaked\|host-async'
    [ -f /tmp/ref/r/surfaces.json ] && mv /tmp/ref/r/surfaces.json "/tmp/ref/groups-$(echo "$run" | tr , -).json"
    echo "reference $run done at $(( $(date +%s) - T0 )) s"
done
tar czf "$OUT/reference.tar.gz" -C /tmp/ref $(cd /tmp/ref && ls *.json 2>/dev/null)
wait
cat /tmp/ans/log
tar czf "$OUT/answers.tar.gz" -C /tmp/ans .
echo "all done at $(( $(date +%s) - T0 )) s"
