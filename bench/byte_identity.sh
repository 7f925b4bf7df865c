#!/usr/bin/env bash
# Byte identity of two revisions' outputs (issue 29, "Must be shown"): builds the `aerorect`
# binary of BASE_REV and HEAD_REV (default: HEAD) in their own worktrees and target dirs
# (bench/revision_bin.sh; binaries cached per commit), runs the same commands with each into
# separate folders, and compares every output file by sha256.
#
#   bench/byte_identity.sh BASE_REV [HEAD_REV] [--cases demo,ngi-mosaic,dji-batch-adjust,dji-mosaic-adjust]
#                          [--pytest VENV]
#
# Cases (the data from ../shared/data, or $AERORECT_SHARED):
#   demo               aerorect demo --out-dir D
#   ngi-mosaic         aerorect mosaic ngi/*.tif --out D/ngi_mosaic.tif --poses ngi/ngi_xyz_opk.csv
#                      --camera ngi/ngi_int_param.yaml --dem ngi/dem.tif --gsd-m 5
#                      (Orthority's NGI frames, poses and interior YAML; 5 m as its config.yaml)
#   dji-batch-adjust   aerorect batch drone-xmp/*.JPG --out-dir D --gsd-m 0.1 --adjust
#                      (the five shared DJI frames, the README's flight at its GSD; about 35 s)
#   dji-mosaic-adjust  aerorect mosaic drone-xmp/*.JPG --out D/m.tif --gsd-m 0.2 --adjust
#                      (0.2 m: at 0.1 m the mosaic is 16764 x 14725 px and takes 76 s a run)
#
# A case whose subcommand or flags a binary lacks (`aerorect SUB --help` does not list them) is
# reported "command not available at REV", a case that fails is reported with its exit code and
# the end of its stderr; neither is counted as identical.
#
# JSON files (.json) are compared with their timing fields masked: every object key containing
# "seconds" (adjustment.json `seconds` and its rounds' `seconds`, the demo and rectify reports'
# `warp_seconds`, `stage_seconds`, `median_seconds`, `detect_seconds`). Everything else in them
# is compared byte for byte: the parsed documents with the exact digits of every number, and
# the texts with every number masked (layout, key order, strings). Every other file: sha256.
# stdout and stderr are kept in OUT/logs, not compared (progress lines and times;
# bench/messages_diff.sh compares messages).
#
# --pytest VENV: VENV is a virtual environment with HEAD_REV's wheel installed (scripts/test-all.sh
# at HEAD_REV leaves one in target/pyenv). HEAD_REV's pytest suite compares the module's outputs
# with the CLI's bytes (conftest.py's `cli` fixture, $AERORECT_BIN); it is run twice, with
# AERORECT_BIN = HEAD_REV's binary and = BASE_REV's, and every test whose outcome differs is
# listed. Both runs passing shows the module at HEAD writes the bytes BASE's CLI writes.
#
# Both binaries write into the same folder, OUT/run/CASE (reports name their output paths),
# moved to OUT/base/CASE and OUT/head/CASE after each run.
# Results: OUT (default $BYTES_WORK/runs/BASE-HEAD) holds base/CASE and head/CASE (removed when
# every file of the case is identical, unless BYTES_KEEP_OUTPUTS=1), logs/ and table.md. Exit 0: every compared file identical; 1: some differ, are missing on one side, or a
# case failed or was not available; 2: usage or build error.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=bench/revision_bin.sh
source "$here/revision_bin.sh"

usage() {
    sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
}

base_rev=
head_rev=
cases=demo,ngi-mosaic,dji-batch-adjust,dji-mosaic-adjust
pyenv=
while [[ $# -gt 0 ]]; do
    case $1 in
    --cases) cases=$2; shift 2 ;;
    --pytest) pyenv=$2; shift 2 ;;
    -h | --help) usage ;;
    -*) echo "error: unknown option $1" >&2; usage ;;
    *) take_rev "$1"; shift ;;
    esac
done
resolve_revs
shared=${AERORECT_SHARED:-$(cd "$repo/.." && pwd)/shared/data}
out=${BYTES_OUT:-$WORK/runs/${base_sha:0:10}-${head_sha:0:10}}
rm -rf "$out"
mkdir -p "$out/logs"

base_bin=$(build_rev "$base_rev")
head_bin=$(build_rev "$head_rev")

ngi=$shared/ngi
dji=$shared/drone-xmp
# Each case: the subcommand, the flags `SUB --help` must list, and the command (D = its folder).
case_sub() {
    case $1 in
    demo) echo demo ;;
    ngi-mosaic | dji-mosaic-adjust) echo mosaic ;;
    dji-batch-adjust) echo batch ;;
    *) echo "error: unknown case $1" >&2; exit 2 ;;
    esac
}
case_flags() {
    case $1 in
    demo) echo --out-dir ;;
    ngi-mosaic) echo --out --poses --camera --dem --gsd-m ;;
    dji-batch-adjust) echo --out-dir --gsd-m --adjust ;;
    dji-mosaic-adjust) echo --out --gsd-m --adjust ;;
    esac
}
case_data() {
    case $1 in
    demo) ;;
    ngi-mosaic) echo "$ngi/dem.tif" ;;
    dji-*) echo "$dji/DJI_0010.JPG" ;;
    esac
}
run_case() { # NAME BIN D
    local d=$3
    case $1 in
    demo) "$2" demo --out-dir "$d" ;;
    ngi-mosaic)
        "$2" mosaic "$ngi"/3324c_2015_1004_0*_RGB.tif --out "$d/ngi_mosaic.tif" \
            --poses "$ngi/ngi_xyz_opk.csv" --camera "$ngi/ngi_int_param.yaml" --dem "$ngi/dem.tif" \
            --gsd-m 5 ;;
    dji-batch-adjust)
        "$2" batch "$dji"/DJI_00*.JPG --out-dir "$d" --gsd-m 0.1 --adjust ;;
    dji-mosaic-adjust)
        "$2" mosaic "$dji"/DJI_00*.JPG --out "$d/m.tif" --gsd-m 0.2 --adjust ;;
    esac
}

# Prints "" when BIN has SUB and every flag, else what is missing.
missing() { # BIN CASE
    local help sub flag gone=()
    sub=$(case_sub "$2")
    if ! help=$("$1" "$sub" --help 2>&1); then
        echo "no subcommand $sub"
        return
    fi
    for flag in $(case_flags "$2"); do
        grep -qE -- "(^|[ ,])$flag([ =,<]|$)" <<<"$help" || gone+=("$flag")
    done
    [[ ${#gone[@]} -eq 0 ]] || echo "$sub has no ${gone[*]}"
}

# JSON compare: exit 0 when equal but for keys containing "seconds".
json_same() {
    python3 - "$1" "$2" <<'EOF'
import json, re, sys

class Num(str):
    pass

def load(path):
    text = open(path, encoding="utf-8").read()
    doc = json.loads(text, parse_float=Num, parse_int=Num, parse_constant=Num,
                     object_pairs_hook=lambda kv: [(k, v) for k, v in kv if "seconds" not in k])
    # The text with every number masked: layout, key order and strings, byte for byte.
    masked = re.sub(r'-?\d+(\.\d+)?([eE][-+]?\d+)?', "N", text)
    return doc, masked

a, b = load(sys.argv[1]), load(sys.argv[2])
sys.exit(0 if a == b else 1)
EOF
}

rows=()
failures=0
compared=0
for c in ${cases//,/ }; do
    case_sub "$c" >/dev/null
    data=$(case_data "$c")
    if [[ -n $data && ! -e $data ]]; then
        rows+=("| $c | - | SKIP: $data is absent | - |")
        failures=$((failures + 1))
        continue
    fi
    skip=
    for side in base head; do
        bin=$base_bin; rev=$base_rev
        [[ $side == head ]] && { bin=$head_bin; rev=$head_rev; }
        why=$(missing "$bin" "$c")
        if [[ -n $why ]]; then
            rows+=("| $c | - | command not available at $rev ($why) | - |")
            skip=1
            continue
        fi
        # Both sides run in the same folder (reports name their paths), then move aside.
        d="$out/run/$c"
        rm -rf "$d"
        mkdir -p "$d" "$out/$side"
        t0=$SECONDS
        set +e
        (cd "$d" && run_case "$c" "$bin" "$d") >"$out/logs/$side-$c.stdout" 2>"$out/logs/$side-$c.stderr"
        rc=$?
        set -e
        mv "$d" "$out/$side/$c"
        echo "$side $c: exit $rc in $((SECONDS - t0)) s" >&2
        if [[ $rc -ne 0 ]]; then
            rows+=("| $c | - | FAILED at $rev (exit $rc): $(grep -v '^\s*$' "$out/logs/$side-$c.stderr" | tail -1 | tr '|' '/') | - |")
            skip=1
        fi
    done
    if [[ -n $skip ]]; then
        failures=$((failures + 1))
        continue
    fi
    mapfile -t files < <( (cd "$out/base/$c" && find . -type f; cd "$out/head/$c" && find . -type f) |
        sed 's|^\./||' | sort -u)
    before=$failures
    for f in "${files[@]}"; do
        a="$out/base/$c/$f"
        b="$out/head/$c/$f"
        compared=$((compared + 1))
        if [[ ! -f $a ]]; then
            rows+=("| $c | $f | only at $head_rev | different |")
            failures=$((failures + 1))
            continue
        elif [[ ! -f $b ]]; then
            rows+=("| $c | $f | only at $base_rev | different |")
            failures=$((failures + 1))
            continue
        fi
        sa=$(sha256sum "$a" | cut -c1-16)
        sb=$(sha256sum "$b" | cut -c1-16)
        if [[ $sa == "$sb" ]]; then
            rows+=("| $c | $f | $sa | same |")
        elif [[ $f == *.json ]] && json_same "$a" "$b"; then
            rows+=("| $c | $f | $sa / $sb | same but for timing fields |")
        else
            rows+=("| $c | $f | $sa / $sb | different |")
            failures=$((failures + 1))
        fi
    done
    # Identical outputs are removed (they are large); differing ones stay for a look.
    if [[ $failures -eq $before && -z ${BYTES_KEEP_OUTPUTS:-} ]]; then
        rm -rf "${out:?}/base/$c" "${out:?}/head/$c"
    fi
done

pytest_rows=()
if [[ -n $pyenv ]]; then
    # HEAD_REV's tests, from a worktree of it.
    src="$WORK/wt/pytest-${head_sha:0:10}"
    [[ -d $src ]] || git -C "$repo" worktree add --detach "$src" "$head_sha" >/dev/null 2>&1
    for side in head base; do
        bin=$head_bin
        [[ $side == base ]] && bin=$base_bin
        set +e
        (cd "$out" && AERORECT_BIN=$bin "$pyenv/bin/python" -m pytest -q -p no:cacheprovider -rA \
            -W ignore::rasterio.errors.NotGeoreferencedWarning "$src/python/tests") \
            >"$out/logs/pytest-$side.txt" 2>&1
        set -e
        grep -E '^(PASSED|FAILED|ERROR|SKIPPED|XFAIL|XPASS) ' "$out/logs/pytest-$side.txt" |
            sed -E 's/ - .*//' | sort >"$out/logs/pytest-$side.outcomes" || true
        echo "pytest with the $side binary: $(tail -1 "$out/logs/pytest-$side.txt")" >&2
    done
    git -C "$repo" worktree remove --force "$src"
    pytest_rows+=("pytest ($head_rev's suite and wheel): with $head_rev's binary: $(tail -1 "$out/logs/pytest-head.txt" | tr -d '=')")
    pytest_rows+=("pytest ($head_rev's suite and wheel): with $base_rev's binary: $(tail -1 "$out/logs/pytest-base.txt" | tr -d '=')")
    if ! diff -q "$out/logs/pytest-head.outcomes" "$out/logs/pytest-base.outcomes" >/dev/null; then
        failures=$((failures + 1))
        while read -r line; do
            pytest_rows+=("  outcome differs: $line")
        done < <(diff "$out/logs/pytest-head.outcomes" "$out/logs/pytest-base.outcomes" | grep '^[<>]' |
            sed -e "s/^</$head_rev binary:/" -e "s/^>/$base_rev binary:/")
    elif grep -q '^FAILED\|^ERROR' "$out/logs/pytest-base.outcomes"; then
        failures=$((failures + 1))
        pytest_rows+=("  failures with both binaries (not caused by the binary): $(grep -c '^FAILED\|^ERROR' "$out/logs/pytest-base.outcomes")")
    else
        pytest_rows+=("  same outcome for every test")
    fi
fi

{
    echo "### $base_rev (${base_sha:0:10}) -> $head_rev (${head_sha:0:10})"
    echo
    echo "| case | file | sha256 (first 16) | verdict |"
    echo "|---|---|---|---|"
    printf '%s\n' "${rows[@]}"
    echo
    echo "$compared files compared; $failures differ, are missing on one side, or a case could not run."
    if [[ ${#pytest_rows[@]} -gt 0 ]]; then
        echo
        printf '%s\n' "${pytest_rows[@]}"
    fi
} | tee "$out/table.md"
[[ $failures -eq 0 ]]
