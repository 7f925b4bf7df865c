#!/bin/sh
# track's per-frame time beside the criterion kernel's (issue 28, item 10). Run it on a quiet
# machine: on a loaded one only the relative figures of step 2 (interleaved) mean anything.
#
#   bench/track_vs_kernel.sh            # THREADS=2, frames in ../shared/data/aerial-seq
#   THREADS=1 AERORECT_SHARED_DATA=/data bench/track_vs_kernel.sh
#
# 1. `aerorect track --method jtc` on the frames: the median of its ms column (the estimate of
#    one pair) and the wall time per frame of the whole run (decoding included);
# 2. examples/track_stages: the same estimator, in one process, interleaved round by round:
#    the criterion setting (one pair over and over, inside the pool), that pair called from
#    outside the pool (as track calls it), the real stream, and decoding one frame;
# 3. criterion's kernel: shift/jtc-2t/256 (two threads) and shift/jtc/256 (one).
set -e
cd "$(dirname "$0")/.."
DATA=${AERORECT_SHARED_DATA:-../shared/data}
FRAMES=$(ls "$DATA"/aerial-seq/*.tiff)
THREADS=${THREADS:-2}
cargo build --release -q -p aerorect-cli
cargo build --release -q -p aerorect --example track_stages
BIN=target/release/aerorect
N=$(echo "$FRAMES" | wc -l)
echo "== 1. aerorect --threads $THREADS track --method jtc ($N frames)"
for i in 1 2 3; do
    start=$(date +%s.%N)
    $BIN --threads "$THREADS" track --method jtc $FRAMES > /tmp/track_vs_kernel.csv
    end=$(date +%s.%N)
    tail -n +2 /tmp/track_vs_kernel.csv | cut -d, -f5 | sort -n | awk -v s="$start" -v e="$end" -v n="$N" \
        '{ v[NR] = $1 } END { printf "track: ms column median %.3f ms, min %.3f ms; wall %.3f ms per frame\n", v[int((NR + 1) / 2)], v[1], (e - s) * 1000 / n }'
done
echo "== 2. the estimator in four settings (interleaved, $THREADS threads)"
RAYON_NUM_THREADS=$THREADS target/release/examples/track_stages 5 $FRAMES
echo "== 3. criterion (shift/jtc-2t/256: two threads; shift/jtc/256: one)"
cargo bench -q -p aerorect-raster --bench shift -- 'shift/jtc(-2t)?/256$' 2>/dev/null \
    | grep -E '^shift/jtc|time:'
