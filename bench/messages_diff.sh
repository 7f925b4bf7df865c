#!/usr/bin/env bash
# The messages a restructuring changed (issue 29, "Messages: a table of every error text that
# changed"): runs every command of a corpus of bad inputs (bench/messages_corpus.txt, or
# --corpus FILE) with BASE_REV's and HEAD_REV's `aerorect` (default HEAD; binaries built and
# cached by bench/revision_bin.sh), each in a fresh copy of one fixture folder at the same path
# (so paths in messages agree), and prints a markdown table of every command whose stderr or
# exit code differs: command | before | after.
#
#   bench/messages_diff.sh BASE_REV [HEAD_REV] [--corpus FILE]
#
# The fixtures (cameras, a simulated frame, DJI photos made from data/aero1.jpg with an XMP
# packet, broken files, a YAML alias bomb, ...) are made once, with HEAD_REV's binary for the
# simulated frame, and are the same bytes for both binaries. Each command gets 60 s
# (exit 124 when cut). Results: OUT (default $BYTES_WORK/messages/BASE-HEAD) holds base/N and
# head/N (stderr and exit code of command N) and table.md.
# Exit 0: every stderr and exit code the same; 1: some differ; 2: usage or build error.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=bench/revision_bin.sh
source "$here/revision_bin.sh"

usage() {
    sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
}
base_rev=
head_rev=
corpus=$here/messages_corpus.txt
while [[ $# -gt 0 ]]; do
    case $1 in
    --corpus) corpus=$2; shift 2 ;;
    -h | --help) usage ;;
    -*) echo "error: unknown option $1" >&2; usage ;;
    *) take_rev "$1"; shift ;;
    esac
done
resolve_revs
out=${MESSAGES_OUT:-$WORK/messages/${base_sha:0:10}-${head_sha:0:10}}
rm -rf "$out"
mkdir -p "$out/base" "$out/head"
base_bin=$(build_rev "$base_rev")
head_bin=$(build_rev "$head_rev")

# Variables the corpus may use.
ATT="azimuth=10,elevation=25,image_rotation=1,pitch=2,roll=-1,yaw=30"
DATA=$repo/data
SHARED=${AERORECT_SHARED:-$(cd "$repo/.." && pwd)/shared/data}
export ATT DATA SHARED
# No backtraces: a user's panic or abort message, not the frames inlining happened to keep
# (which differ between builds of the same code).
export RUST_BACKTRACE=0

fix="$out/fixtures"
mkdir -p "$fix/adir"
(
    cd "$fix"
    cp "$DATA/aero1.jpg" scene.jpg
    printf 'fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n' >cam.toml
    printf 'focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nimage_size_px = [320, 240]\n' >cam320.toml
    printf 'focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nimage_size_px = [640, 640]\n' >cam640.toml
    printf 'focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nfocal = 3\n' >bad_unknown.toml
    printf 'pixel_pitch_um = [15.0, 15.0]\n' >bad_missing.toml
    printf 'focal_length_mm = 0.0\npixel_pitch_um = [15.0, 15.0]\n' >bad_zero.toml
    printf 'focal_length_mm = 6.0\npixel_pitch_um = [-15.0, 15.0]\n' >bad_negative.toml
    printf 'focal_length_mm = inf\npixel_pitch_um = [15.0, 15.0]\n' >bad_inf.toml
    printf 'fx_px = 1e308\nfy_px = 500.0\nimage_size_px = [640, 480]\n' >absurd_fx.toml
    printf 'fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n[distortion]\nmodel = "opencv"\nk1 = 1e308\n' >absurd_k1.toml
    printf 'fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [4000000000, 3000000000]\n' >absurd_size.toml
    printf 'azimuth = 1\nelevation = 2\nimage_rotation = 0\npitch = 0\nroll = 0\nyaw = 0\nheading = 4\n' >att_unknown.toml
    printf 'x' >plain.txt
    printf 'not a jpeg' >bad.jpg
    printf 'II*\0 this is not really a tiff' >text.tif
    printf 'filename,x,y,z,omega,phi,kappa\na,536138.4,5972535.9,310,0,0,0\n' >gposes.csv
    printf 'garbage, not a CRS' >gposes.prj
    printf 'EPSG:32635\n536138.4 5972535.9 230.0 320 240\n' >gcp_bad.txt
    printf 'EPSG:32635\n536138.4 5972535.9 230.0 320 240 a.jpg p1\n536148.4 5972535.9 230.0 340 240 b.jpg p2\n' >gcp_ok.txt
    printf 'image,X,Y,u,v\nleft01.jpg,0,0,10,10\n' >corners_bad.csv
    python3 - "$DATA/aero1.jpg" <<'EOF'
import sys

jpeg = open(sys.argv[1], "rb").read()

def photo(name, lat="+53.900000", heights='drone-dji:AbsoluteAltitude="+310.00" drone-dji:RelativeAltitude="+80.00"',
          pitch="-80.00", yaw="+30.00"):
    xmp = ('<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">'
           '<rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" '
           f'drone-dji:GpsLatitude="{lat}" drone-dji:GpsLongtitude="+27.550000" {heights} '
           f'drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="{yaw}" '
           f'drone-dji:GimbalPitchDegree="{pitch}" drone-dji:FlightYawDegree="+0.00"/></rdf:RDF></x:xmpmeta>')
    payload = b"http://ns.adobe.com/xap/1.0/\0" + xmp.encode()
    data = jpeg[:2] + b"\xff\xe1" + (len(payload) + 2).to_bytes(2, "big") + payload + jpeg[2:]
    open(name, "wb").write(data)
    return data

a = photo("a.jpg")
open("copy.jpg", "wb").write(a)
photo("b.jpg", heights='drone-dji:AbsoluteAltitude="+311.00" drone-dji:RelativeAltitude="+81.00"')
photo("p.jpg", heights='drone-dji:RelativeAltitude="+80.00"', pitch="-90.00", yaw="+0.00")
photo("abs.jpg", heights='drone-dji:AbsoluteAltitude="+310.00"')
photo("high.jpg", heights='drone-dji:AbsoluteAltitude="+310.00" drone-dji:RelativeAltitude="+1e308"')
photo("far.jpg", lat="+61.990000", pitch="-90.00", yaw="+0.00")
open("noxmp.jpg", "wb").write(jpeg)
# A YAML alias bomb: 10^9 scalars once expanded.
s = "a0: &a0 [lol]\n"
for i in range(1, 10):
    s += f"a{i}: &a{i} [" + ",".join([f"*a{i-1}"] * 10) + "]\n"
open("bomb.yaml", "w").write(s)
EOF
    "$head_bin" simulate scene.jpg frame.png --camera cam320.toml --attitude "$ATT" \
        --checkpoints 25 --checkpoints-out cp.csv >/dev/null
    head -c "$(($(stat -c %s frame.png) / 2))" frame.png >cut.png
    python3 - <<'EOF'
lines = open("cp.csv").read().splitlines()
cols = lines[0].split(",")
row = lines[1].split(",")
row[cols.index("u_standard") if "u_standard" in cols else 0] = "1e308"
lines[1] = ",".join(row)
open("huge.csv", "w").write("\n".join(lines) + "\n")
EOF
)

mapfile -t cmds < <(grep -v '^\s*#' "$corpus" | grep -v '^\s*$')
scratch="$out/run"
args=()
for side in base head; do
    bin=$base_bin
    [[ $side == head ]] && bin=$head_bin
    for i in "${!cmds[@]}"; do
        rm -rf "$scratch"
        cp -a "$fix" "$scratch"
        eval "args=(${cmds[$i]})"
        set +e
        (cd "$scratch" && timeout 60 "$bin" "${args[@]}") >/dev/null 2>"$out/$side/$i.stderr" </dev/null
        echo $? >"$out/$side/$i.rc"
        set -e
    done
    echo "$side: ${#cmds[@]} commands run" >&2
done
rm -rf "$scratch"

cell() { # RC FILE: exit code and stderr on one table cell
    local text
    text=$(sed -e 's/|/\\|/g' -e 's/`/'"'"'/g' "$2" | awk 'NR>1{printf "<br>"} {printf "%s", $0}')
    echo "exit $1: $text"
}
differ=0
{
    echo "### messages: $base_rev (${base_sha:0:10}) -> $head_rev (${head_sha:0:10})"
    echo
    echo "| command | before | after |"
    echo "|---|---|---|"
    for i in "${!cmds[@]}"; do
        rb=$(cat "$out/base/$i.rc")
        rh=$(cat "$out/head/$i.rc")
        if [[ $rb != "$rh" ]] || ! cmp -s "$out/base/$i.stderr" "$out/head/$i.stderr"; then
            differ=$((differ + 1))
            echo "| \`aerorect ${cmds[$i]//|/\\|}\` | $(cell "$rb" "$out/base/$i.stderr") | $(cell "$rh" "$out/head/$i.stderr") |"
        fi
    done
    echo
    echo "${#cmds[@]} commands; $differ with a different stderr or exit code."
} >"$out/table.md"
cat "$out/table.md"
grep -q "; 0 with a different" "$out/table.md"
