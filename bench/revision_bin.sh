# shellcheck shell=bash
# Sourced by bench/byte_identity.sh and bench/messages_diff.sh: builds the `aerorect` binary of
# a git revision in its own detached worktree with its own target dir, and caches the binary.
#
#   BYTES_WORK   scratch root (default: <repo>/target/byte-identity): wt/SHA (worktrees, removed
#                after the build), target/SHA (target dirs), bin/SHA/aerorect (cached binaries),
#                logs/ (build logs)
#   BYTES_SEED   a target dir to seed the first build from (default: the newest target dir under
#                BYTES_WORK/target, else <repo>/target): its release/ is copied with `cp -a`, so
#                the dependencies are not compiled again; only the workspace crates are
#   BYTES_KEEP_TARGETS  how many target dirs to keep under BYTES_WORK/target (default 2; the
#                newest ones, which seed the next build)
#
# A binary is built once per commit: bin/SHA/aerorect is reused on the next run.

repo=$(git rev-parse --show-toplevel)
WORK=${BYTES_WORK:-$repo/target/byte-identity}
mkdir -p "$WORK/bin" "$WORK/wt" "$WORK/target" "$WORK/logs"

# Full sha of REV (a commit), or exit 2.
rev_sha() {
    git -C "$repo" rev-parse --verify --quiet "$1^{commit}" || {
        echo "error: $1 is not a commit of $repo" >&2
        exit 2
    }
}

# The newest target dir under $WORK/target (by mtime), else $BYTES_SEED, else <repo>/target.
seed_target() {
    local newest
    newest=$(find "$WORK/target" -mindepth 1 -maxdepth 1 -type d -printf '%T@ %p\n' 2>/dev/null |
        sort -rn | head -1 | cut -d' ' -f2-)
    if [[ -n ${BYTES_SEED:-} ]]; then
        echo "$BYTES_SEED"
    elif [[ -n $newest ]]; then
        echo "$newest"
    elif [[ -d $repo/target/release ]]; then
        echo "$repo/target"
    fi
}

# Keeps the newest $BYTES_KEEP_TARGETS target dirs under $WORK/target.
prune_targets() {
    local keep=${BYTES_KEEP_TARGETS:-2} old
    find "$WORK/target" -mindepth 1 -maxdepth 1 -type d -printf '%T@ %p\n' | sort -rn |
        tail -n +"$((keep + 1))" | cut -d' ' -f2- | while read -r old; do
        rm -rf "$old"
    done
}

# Prints the path of REV's `aerorect` binary, building it first when it is not cached.
# Build output goes to $WORK/logs/build-SHA.log.
build_rev() {
    local sha bin wt tgt seed log
    sha=$(rev_sha "$1")
    bin="$WORK/bin/$sha/aerorect"
    if [[ -x $bin ]]; then
        echo "$bin"
        return
    fi
    wt="$WORK/wt/$sha"
    tgt="$WORK/target/$sha"
    log="$WORK/logs/build-$sha.log"
    if [[ ! -d $wt ]]; then
        git -C "$repo" worktree add --detach "$wt" "$sha" >"$log" 2>&1
    fi
    if [[ ! -d $tgt ]]; then
        seed=$(seed_target)
        mkdir -p "$tgt"
        if [[ -n $seed && -d $seed/release ]]; then
            echo "build $1 (${sha:0:10}): seeding $tgt from $seed" >&2
            cp -a "$seed/release" "$tgt/release"
        fi
    fi
    echo "build $1 (${sha:0:10}): cargo build --release -p aerorect-cli (log: $log)" >&2
    local t0=$SECONDS
    if ! (cd "$wt" && CARGO_TARGET_DIR="$tgt" nice -n 15 cargo build --release -p aerorect-cli) >>"$log" 2>&1; then
        tail -20 "$log" >&2
        echo "error: the build of $1 failed (log: $log)" >&2
        exit 2
    fi
    echo "build $1 (${sha:0:10}): $((SECONDS - t0)) s" >&2
    mkdir -p "$(dirname "$bin")"
    cp "$tgt/release/aerorect" "$bin"
    touch "$tgt"
    git -C "$repo" worktree remove --force "$wt"
    prune_targets
    echo "$bin"
}

# The two revisions as the scripts take them, positionally: BASE_REV, then HEAD_REV; a third
# is a usage error (the calling script's `usage`).
take_rev() {
    if [[ -z ${base_rev:-} ]]; then base_rev=$1
    elif [[ -z ${head_rev:-} ]]; then head_rev=$1
    else usage
    fi
}

# After the arguments: BASE_REV is required and HEAD_REV defaults to HEAD; sets base_sha and
# head_sha (exit 2 for a revision that is not a commit).
resolve_revs() {
    [[ -n ${base_rev:-} ]] || usage
    head_rev=${head_rev:-HEAD}
    base_sha=$(rev_sha "$base_rev")
    head_sha=$(rev_sha "$head_rev")
}
