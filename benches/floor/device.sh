#!/bin/sh
# The device run of the floor reference (see docs/accuracy.md): from the repository root on
# the lent GPU machine, with the trimmed Mitsuba wheel in .whl/mi.zip (and, optionally, a
# gzipped release relight binary in .whl/relight.gz, baked on the machine's CPUs meanwhile).
# Results go to $OUT/reference (and $OUT/bake.log, $OUT/hierarchical.json).
set -e
T0=$(date +%s)
PY=${PY:-python3}
if [ -z "$LOCAL_TEST" ]; then
    python3 -m zipfile -e .whl/mi.zip /tmp/site
    export PYTHONPATH=/tmp/site
fi
$PY benches/floor/make_scene.py /tmp/floor 0.25
if [ -f .whl/relight.gz ]; then
    gunzip -c .whl/relight.gz > /tmp/relight && chmod +x /tmp/relight
    ( cd /tmp && timeout "${BAKE_S:-420}" /tmp/relight bake /tmp/floor --cache /tmp/c --transfer hierarchical \
          > "$OUT/bake.log" 2>&1 \
      && /tmp/relight radiosity /tmp/floor --json --transfer hierarchical --cache /tmp/c \
          > "$OUT/hierarchical.json" 2>> "$OUT/bake.log"; echo "bake exit $? at $(( $(date +%s) - T0 )) s" >> "$OUT/bake.log" ) &
fi
nvidia-smi --query-gpu=name,memory.total --format=csv,noheader || true
MI_VARIANT=${MI_VARIANT:-cuda_ad_rgb} $PY benches/floor/reference.py /tmp/floor "$OUT/reference" \
    --points 65536 --passes 8 --brute s2_desk1_top,s2_floor --brute-points 4194304 \
    --spp 4096 --pass-spp 256 ${REF_ARGS:-} 2>&1 | grep -a -v 'still being referenced\|jit_\|skipping remainder\|leaked\|host-async'
echo "reference done at $(( $(date +%s) - T0 )) s"
wait
echo "all done at $(( $(date +%s) - T0 )) s"
