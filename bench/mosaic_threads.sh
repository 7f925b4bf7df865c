#!/usr/bin/env bash
# The snowpeak mosaic (the senseFly eBee photos of ../shared/data/flights/snowpeak, 23194 x
# 19274 px at their native 3 cm, 1748 tiles) by two `aerorect` binaries, on every thread and on
# one: wall and CPU time and peak RSS (/usr/bin/time -v) of each, and whether the files are the
# same bytes. The runs alternate between the binaries, so both see the same load; note the load
# (uptime, printed) next to the numbers.
#
#   bench/mosaic_threads.sh BEFORE_BIN AFTER_BIN [OUT_DIR]
#
# OUT_DIR (default /tmp/mosaic_threads) holds the mosaics and the /usr/bin/time reports.
set -euo pipefail
[[ $# -ge 2 ]] || { sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
before=$1 after=$2 out=${3:-/tmp/mosaic_threads}
data=${AERORECT_SHARED:-$(cd "$(dirname "$0")/../.." && pwd)/shared/data}
photos=("$data"/flights/snowpeak/img/*.JPG)
mkdir -p "$out"
for threads in all 1; do
    flag=()
    [[ $threads == all ]] || flag=(--threads "$threads")
    for side in before after; do
        bin=$before
        [[ $side == after ]] && bin=$after
        tag=$side-$threads
        uptime
        /usr/bin/time -v "$bin" mosaic "${photos[@]}" --out "$out/$tag.tif" \
            --ground-height-m 160 "${flag[@]}" >/dev/null 2>"$out/$tag.time"
        printf '%-12s %s\n' "$tag" "$(grep -E 'Elapsed|User time|Maximum resident' "$out/$tag.time" |
            sed 's/.*: //' | paste -sd' ' | awk '{print "user " $1 " s, wall " $2 ", peak RSS " $3 " KB"}')"
    done
    if cmp -s "$out/before-$threads.tif" "$out/after-$threads.tif"; then
        echo "threads $threads: the same bytes"
    else
        echo "threads $threads: the files differ"
    fi
done
